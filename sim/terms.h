#pragma once
// The one place where runtime choices become template parameters (hoomd-blue
// PotentialPairGPU.cuh style). CompiledTermSets is the complete, explicit list of pass variants
// built into the binary; a scene selects one of them and pays for nothing else.
#include <string>
#include <type_traits>

#include "mesorock/errors.h"
#include "sim/model.h"
#include "sim/pair_terms.h"
#include "sim/wall_model.h"

namespace mesorock::sim {

template <class C, class T, class B, class W = NoWallModel>
struct TermSet {
  using conservative = C;
  using thermostat = T;
  using body_force = B;
  using wall_model = W;
};

template <class... Ts>
struct TypeList {};

// Per conservative term: 2 thermostat x 3 body force without the wall model, and the wall model
// where it makes sense (thermostat on: its no-slip condition is a dissipation; body force off or
// uniform). 3 conservative x 8 = 24 variants per precision.
template <class C>
using TermSetsFor =
    TypeList<TermSet<C, NoThermostat, NoBodyForce>, TermSet<C, NoThermostat, PerTypeBodyForce>,
             TermSet<C, NoThermostat, ReversedBodyForce>, TermSet<C, DPDThermostat, NoBodyForce>,
             TermSet<C, DPDThermostat, PerTypeBodyForce>,
             TermSet<C, DPDThermostat, ReversedBodyForce>,
             TermSet<C, DPDThermostat, NoBodyForce, BoundaryVolumeFractionWalls>,
             TermSet<C, DPDThermostat, PerTypeBodyForce, BoundaryVolumeFractionWalls>>;

template <class... Lists>
struct ConcatLists;
template <class... A>
struct ConcatLists<TypeList<A...>> {
  using type = TypeList<A...>;
};
template <class... A, class... B, class... Rest>
struct ConcatLists<TypeList<A...>, TypeList<B...>, Rest...> {
  using type = typename ConcatLists<TypeList<A..., B...>, Rest...>::type;
};

using CompiledTermSets =
    typename ConcatLists<TermSetsFor<ConservativeDPD>,
                         TermSetsFor<ConservativeMDPD<DensityKernelWarren>>,
                         TermSetsFor<ConservativeMDPD<DensityKernelLucy>>>::type;

template <class List>
struct ListSize;
template <class... Ts>
struct ListSize<TypeList<Ts...>> {
  static constexpr int value = static_cast<int>(sizeof...(Ts));
};
// ARCHITECTURE.md and the comment above state this count; change them with it.
static_assert(ListSize<CompiledTermSets>::value == 24, "update ARCHITECTURE.md's variant count");

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
  using B = typename Terms::body_force;
  bool body;
  if constexpr (!B::enabled) {
    body = !m.has_body_force();
  } else if constexpr (std::is_same_v<B, PerTypeBodyForce>) {
    body = m.has_body_force() && m.body_force_profile == BodyForceProfile::Uniform;
  } else {
    body = m.has_body_force() && m.body_force_profile == BodyForceProfile::Reversed;
  }
  return cons && Terms::thermostat::enabled == m.thermostat && body &&
         Terms::wall_model::enabled == m.wall_model.enabled;
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
    throw ConfigError(
        m.wall_model.enabled
            ? "no compiled pass for this combination of effects (the wall model needs the "
              "thermostat, and a uniform body force or none)"
            : "no compiled pass for this combination of effects");
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
  if constexpr (Terms::wall_model::enabled) s += std::string(" walls=") + Terms::wall_model::name;
  return s;
}

}  // namespace mesorock::sim
