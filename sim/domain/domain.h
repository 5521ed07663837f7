#pragma once
// How a Simulation spreads over ranks. sim/simulation.cpp holds the one Simulation class; it owns
// this rank's solver (RankSolver) and a Domain: one rank holding the whole box (OneRank, in
// sim/simulation.cpp) or a domain decomposition (sim/domain/distributed.cpp, with the engine's
// StepHooks). Every observable is written once, in the Simulation, as a sum over this rank's own
// particles reduced through comm() (one rank: a communicator of itself, whose reductions leave
// the values as they are); particle outputs are gathered through it and put in the caller's
// original order by original_index(). Every call of a decomposed run is collective.
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "sim/domain/communicator.h"
#include "sim/domain/exchange.h"
#include "sim/simulation.h"
#include "sim/state.h"

namespace mesorock::sim {

// This rank's engine and the host copy of its storage, downloaded when first read after steps.
template <class Real>
struct RankSolver {
  HostState<Real> host;
  std::unique_ptr<Engine<Real>> engine;
  bool host_current = false;

  HostState<Real>& synced() {
    if (!host_current) {
      engine->download(host);
      host_current = true;
    }
    return host;
  }
  // f(i) for every stored particle this rank owns (ghosts have origin < 0).
  template <class F>
  void for_owned(F&& f) {
    synced();
    for (int i = 0; i < host.size(); ++i)
      if (host.origin[i] >= 0) f(i);
  }
};

template <class Real>
class Domain {
 public:
  virtual ~Domain() = default;
  // Whether the box is cut into regions (on one rank too, when the options force it): the
  // storage then holds ghosts, a checkpoint is gathered in the original order, and set-up is
  // collective.
  virtual bool decomposed() const = 0;
  virtual Communicator& comm() const = 0;
  // Fills the solver's host state with this rank's share of the whole particle set p (one rank:
  // all of it) and, resuming, with its rows of `resume` (a saved state whose particles are p).
  virtual void init_state(const Model& model, const BoxSpec& box, const ParticleSet& p, double dt,
                          const SimulationOptions& options, const SimulationState* resume) = 0;
  // What the engine calls between the phases of a step; SerialHooks on one rank (nothing to
  // exchange, identity reductions).
  virtual StepHooks<Real>* hooks() = 0;
  // After the engine's first force pass (or its restore).
  virtual void started() {}
  // How many of `steps` the engine takes before the domain acts again (a re-balance), and what
  // it does just before and after them.
  virtual std::uint64_t steps_in_one_go(std::uint64_t steps) { return steps; }
  virtual void before_steps() {}
  virtual void after_steps() {}
  // A gathered particle's index in the caller's order, from its origin and id.
  virtual std::size_t original_index(std::int32_t origin, std::int64_t id) const = 0;
  virtual std::vector<double> rank_costs() { return {}; }
  virtual std::string report() const { return ""; }
};

// The decomposition over options.comm's ranks (sim/domain/distributed.cpp).
template <class Real>
std::unique_ptr<Domain<Real>> make_decomposed_domain(RankSolver<Real>& solver,
                                                     const SimulationOptions& options);

}  // namespace mesorock::sim
