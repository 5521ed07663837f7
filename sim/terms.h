#pragma once
// The one place where runtime choices become template parameters (hoomd-blue
// PotentialPairGPU.cuh style). CompiledTermSets is the complete, explicit list of pass variants
// built into the binary; a scene selects one of them and pays for nothing else.
#include <string>
#include <type_traits>

#include "mesorock/errors.h"
#include "sim/model.h"
#include "sim/pair_terms.h"

namespace mesorock::sim {

template <class C, class T, class B>
struct TermSet {
  using conservative = C;
  using thermostat = T;
  using body_force = B;
};

template <class... Ts>
struct TypeList {};

// 3 conservative x 2 thermostat x 2 body force = 12 variants per precision.
using CompiledTermSets =
    TypeList<TermSet<ConservativeDPD, NoThermostat, NoBodyForce>,
             TermSet<ConservativeDPD, NoThermostat, PerTypeBodyForce>,
             TermSet<ConservativeDPD, DPDThermostat, NoBodyForce>,
             TermSet<ConservativeDPD, DPDThermostat, PerTypeBodyForce>,
             TermSet<ConservativeMDPD<DensityKernelWarren>, NoThermostat, NoBodyForce>,
             TermSet<ConservativeMDPD<DensityKernelWarren>, NoThermostat, PerTypeBodyForce>,
             TermSet<ConservativeMDPD<DensityKernelWarren>, DPDThermostat, NoBodyForce>,
             TermSet<ConservativeMDPD<DensityKernelWarren>, DPDThermostat, PerTypeBodyForce>,
             TermSet<ConservativeMDPD<DensityKernelLucy>, NoThermostat, NoBodyForce>,
             TermSet<ConservativeMDPD<DensityKernelLucy>, NoThermostat, PerTypeBodyForce>,
             TermSet<ConservativeMDPD<DensityKernelLucy>, DPDThermostat, NoBodyForce>,
             TermSet<ConservativeMDPD<DensityKernelLucy>, DPDThermostat, PerTypeBodyForce>>;

template <class Terms>
bool term_set_matches(const Model& m) {
  using C = typename Terms::conservative;
  bool cons;
  if constexpr (std::is_same_v<C, ConservativeDPD>) {
    cons = m.conservative == ConservativeKind::DPD;
  } else if constexpr (std::is_same_v<C, ConservativeMDPD<DensityKernelWarren>>) {
    cons =
        m.conservative == ConservativeKind::MDPD && m.density_kernel == DensityKernelKind::Warren;
  } else {
    cons = m.conservative == ConservativeKind::MDPD && m.density_kernel == DensityKernelKind::Lucy;
  }
  return cons && Terms::thermostat::enabled == m.thermostat &&
         Terms::body_force::enabled == m.has_body_force();
}

namespace detail {
template <class F, class First, class... Rest>
void dispatch(const Model& m, F& f) {
  if (term_set_matches<First>(m)) {
    f(First{});
    return;
  }
  if constexpr (sizeof...(Rest) > 0) {
    dispatch<F, Rest...>(m, f);
  } else {
    throw ConfigError("no compiled pass for this combination of effects");
  }
}
template <class F, class... Ts>
void dispatch_list(const Model& m, F& f, TypeList<Ts...>) {
  dispatch<F, Ts...>(m, f);
}
}  // namespace detail

// Calls f(Terms{}) with the compiled term set that the model asks for.
template <class F>
void dispatch_terms(const Model& m, F&& f) {
  detail::dispatch_list(m, f, CompiledTermSets{});
}

// Human-readable name of the pass variant, recorded in outputs.
template <class Terms>
std::string term_set_name() {
  std::string s = std::string("conservative=") + Terms::conservative::name;
  if constexpr (Terms::conservative::needs_density)
    s += std::string("/") + Terms::conservative::density_kernel::name;
  s += std::string(" thermostat=") + Terms::thermostat::name;
  s += std::string(" body_force=") + Terms::body_force::name;
  return s;
}

}  // namespace mesorock::sim
