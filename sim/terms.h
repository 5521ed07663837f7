#pragma once
// The one place where runtime choices become template parameters (hoomd-blue
// PotentialPairGPU.cuh style). CompiledTermSets is the complete, explicit list of pass variants
// built into the binary; a scene selects one of them and pays for nothing else. The pair terms'
// parameters are read, checked and tabulated by looping over the same lists (bottom of the file).
#include <set>
#include <string>

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

// The pair terms, by kind: a model selects one of each (T::matches). A new term is one file in
// sim/terms/ and one entry here.
using ConservativeTerms = TypeList<ConservativeDPD, ConservativeMDPD<DensityKernelWarren>,
                                   ConservativeMDPD<DensityKernelLucy>>;
using ThermostatTerms = TypeList<NoThermostat, DPDThermostat>;

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

template <class Conservatives>
struct TermSetsForAll;
template <class... Cs>
struct TermSetsForAll<TypeList<Cs...>> {
  using type = typename ConcatLists<TermSetsFor<Cs>...>::type;
};

using CompiledTermSets = typename TermSetsForAll<ConservativeTerms>::type;

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
  return Terms::conservative::matches(m) && Terms::thermostat::matches(m) &&
         Terms::body_force::matches(m) && Terms::wall_model::enabled == m.wall_model.enabled;
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

// ---------------------------------------------------------------------------------------------
// The pair terms' parameters: each function loops over the kinds, and within a kind over its
// terms, calling the selected one.

namespace detail {
template <class Term, class... Ts>
void forbid_keys_of_others(PairEntry& e) {
  const auto chosen_has = [](const char* key) {
    for (const char* k : Term::pair_keys)
      if (std::string(k) == key) return true;
    return false;
  };
  const auto forbid = [&](const auto& keys) {
    for (const char* k : keys)
      if (!chosen_has(k)) e.forbid(k, Term::chosen_when);
  };
  (forbid(Ts::pair_keys), ...);
}

// Calls f(Term{}) for the term of the list that the model selects.
template <class F, class... Ts>
void with_selected(const Model& m, TypeList<Ts...>, F&& f) {
  const auto call_if_selected = [&](auto term) {
    if (!decltype(term)::matches(m)) return false;
    f(term);
    return true;
  };
  (void)(call_if_selected(Ts{}) || ...);
}

template <class... Ts>
void add_keys(std::set<std::string>& keys, TypeList<Ts...>) {
  const auto add = [&](const auto& list) { keys.insert(list.begin(), list.end()); };
  (add(Ts::pair_keys), ...);
}

template <class... Ts>
void read_pair_of_kind(const Model& m, PairEntry& e, PairSpec& p, TypeList<Ts...> terms) {
  with_selected(m, terms, [&](auto term) {
    using Term = decltype(term);
    forbid_keys_of_others<Term, Ts...>(e);
    Term::read_pair(e, p);
  });
}
}  // namespace detail

// Every key a [[pairs]] entry may give besides "types", whatever the model.
inline std::set<std::string> pair_term_keys() {
  std::set<std::string> keys;
  detail::add_keys(keys, ConservativeTerms{});
  detail::add_keys(keys, ThermostatTerms{});
  return keys;
}

// Reads one [[pairs]] entry into p: per kind, the keys of the terms not selected are forbidden,
// then the selected term reads and checks its own.
inline void read_pair_terms(const Model& m, PairEntry& e, PairSpec& p) {
  detail::read_pair_of_kind(m, e, p, ConservativeTerms{});
  detail::read_pair_of_kind(m, e, p, ThermostatTerms{});
}

// The selected terms' checks of one pair of a model (throws ConfigError).
inline void check_pair_terms(const Model& m, const PairSpec& p) {
  const auto check = [&](auto term) { decltype(term)::check_pair(p); };
  detail::with_selected(m, ConservativeTerms{}, check);
  detail::with_selected(m, ThermostatTerms{}, check);
}

// One row of the device table: the selected terms fill their fields, the rest stay 0.
template <class Real>
PairParams<Real> pair_params(const Model& m, const PairSpec& p) {
  PairParams<Real> row;
  const auto fill = [&](auto term) { decltype(term)::fill_pair(p, m, row); };
  detail::with_selected(m, ConservativeTerms{}, fill);
  detail::with_selected(m, ThermostatTerms{}, fill);
  return row;
}

}  // namespace mesorock::sim
