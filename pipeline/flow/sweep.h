#pragma once
// Permeability sweeps (`rockflow sweep`, docs/permeability.md): steady body-force flow through a
// prepared sample at several driving strengths, each run to a detected steady state, the flow
// rate measured with an error bar, the apparent permeability k = mu q / G, and fits of Darcy's
// law and of a Forchheimer-type quadratic.
//
// Definitions. A body force g per driven particle (m = 1) along the flow axis is, for the Stokes
// equations of the fluid, the same as a mean pressure gradient G = n_f g (n_f the fluid's number
// density): write p = p' - n_f g x. The number flux density J = sum_i v_i / V_total over the
// driven particles, and the Darcy (superficial) velocity q = J / n_f: the volumetric flux per
// unit of the sample's total cross-section. Then k = mu q / G = mu J / (n_f^2 g), with mu the
// fluid's shear viscosity. The fluid's volume V_fluid = N_f / n_f gives the porosity estimate
// phi = V_fluid / V_total.
//
// Steady state. After `warmup_steps`, J is averaged over blocks of `block_steps` (sampled every
// `sample_every`). The flow is steady when the mean of the last `window` blocks agrees with the
// mean of the `window` blocks before within `tolerance` (relative) or within two combined
// standard errors (noise-dominated flows). Then `measure_blocks` further blocks give J and its
// error (the standard error of the block means; blocks are meant to be longer than the flow's
// correlation time). A point that is not steady after `max_steps` is measured on its last
// blocks and flagged. A measurement whose blocks still trend (the least-squares slope of J
// against the block index beyond Student's t_99 standard errors: a flux still falling, say) is
// thrown away and the point waits for a steady flow again.
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "pipeline/flow/darcy_fit.h"
#include "pipeline/flow/leak_invariant.h"
#include "pipeline/scene.h"
#include "sim/model.h"
#include "sim/simulation.h"
#include "sim/units.h"

namespace mesorock::pipeline {

class ProgressMeter;

struct SweepOptions {
  std::vector<double> forces;      // g per driven particle; run in ascending order
  int axis = 0;                    // flow axis
  std::uint32_t driven_types = 0;  // bit t: type t is driven and counted
  double fluid_density = 0;        // n_f
  double viscosity = 0, viscosity_error = 0;
  double dt = 0.01;
  std::uint64_t warmup_steps = 2000;
  std::uint64_t block_steps = 1000;
  std::uint64_t sample_every = 10;
  int window = 3;
  double tolerance = 0.05;
  int measure_blocks = 10;
  std::uint64_t max_steps = 100000;  // per driving strength, warm-up included
  // Each point starts from the last point's final state (less warm-up); false: all from the
  // sample's initial particles.
  bool chain = true;
  // Every point from the prepared particles (not chained), all at once, each on a host thread of
  // its own (sim/ensemble.h): on the GPU the points' steps overlap, on the CPU they share the
  // cores. Each point computes every bit it computes in an unchained sweep one point at a time.
  bool side_by_side = false;
  // Stages run once before the first point (steps, dt): the scene's stages before its last, such
  // as the relax stage at a small dt that takes a freshly packed sample's overlaps out. A sweep
  // that started a packed rock at dt = 0.01 and g = 0.16 ran away in 219 steps.
  std::vector<std::pair<std::uint64_t, double>> prepare;
  // Type masks whose fluxes are also measured apart (the two fluids of `rockflow relperm`); a
  // point is steady only when the total and every phase's flux are.
  std::vector<std::uint32_t> phases;
  sim::SimulationOptions sim;
  ProgressMeter* meter = nullptr;
};

// The flux of one of SweepOptions::phases at a point (J over that phase's particles only).
struct PhaseFlux {
  double flux = 0, flux_error = 0;
  std::vector<double> block_flux;  // J of every block after the warm-up, in order
  double drift = 0, drift_error = 0;
};

struct SweepPoint {
  double force = 0;                                     // g
  double gradient = 0;                                  // G = n_f g
  double flux = 0, flux_error = 0;                      // J
  double darcy_velocity = 0, darcy_velocity_error = 0;  // q = J / n_f
  double permeability = 0, permeability_error = 0;      // k = mu q / G, rc^2 (mu's error too)
  bool steady = false;
  std::uint64_t steady_after = 0;  // steps of this point when the steady state was detected
  std::uint64_t steps = 0;         // steps run for this point
  double temperature = 0;          // kinetic temperature at the end (flow included)
  std::vector<double> block_flux;  // J of every block after the warm-up, in order
  // The trend of J over the measured blocks: its change across them relative to J, with its
  // error; a significant trend (beyond t_99 standard errors) restarts the measurement.
  double drift = 0, drift_error = 0;
  int restarts = 0;               // measurements thrown away for a drifting flux
  LeakRecord leaks;               // the leak invariant at every block (scenes with a solid grid)
  std::vector<PhaseFlux> phases;  // one per SweepOptions::phases
  double seconds = 0;  // wall time of this point's steps (set-up and measurement included)
};

struct SweepSample {
  sim::Model model;
  sim::BoxSpec box;
  sim::ParticleSet particles;
};

// Checks the options against the sample (ConfigError naming the problem) and runs the sweep.
std::vector<SweepPoint> run_sweep(const SweepSample& sample, const SweepOptions& options);

// Checks everything in `options` but the force list against the sample (ConfigError naming the
// problem): what run_sweep and run_steady_point check before any step.
void check_steady_options(const SweepSample& sample, const SweepOptions& options);

// The scene's stages before its last (SweepOptions::prepare) run once on `sample` with every
// body force off; returns the particles they leave (the sample's own when there are none).
sim::ParticleSet prepare_sample(const SweepSample& sample, const SweepOptions& options);

// One steady-state point on its own (what run_sweep does for each force): `from` driven by `force`
// along options.axis with the model's seed replaced by `seed`; `label` names it on the progress
// line; `final_state`, when given, receives its last particles. The options are checked as
// run_sweep checks them (their force list is not used).
SweepPoint run_steady_point(const SweepSample& sample, const SweepOptions& options, double force,
                            std::uint64_t seed, const std::string& label,
                            const sim::ParticleSet& from, const sim::SimulationOptions& sim_options,
                            sim::ParticleSet* final_state = nullptr);

// Darcy through the origin (q = (k / mu) G), a line with an intercept, and the quadratic
// q = c1 G + c2 G^2 (Forchheimer-type: to first order G = q / c1 - (c2 / c1^3) q^2).
struct SweepFits {
  LineFit darcy;                          // slope = k / mu
  std::optional<LineFit> line;            // 2+ points
  std::optional<QuadraticFit> quadratic;  // 3+ points
  double k = 0, k_error = 0;              // mu x slope, error with mu's
};
SweepFits fit_sweep(const std::vector<SweepPoint>& points, double viscosity,
                    double viscosity_error);

// --------------------------------------------------------------------------------------------
// The command: scene -> sweep -> OUT/sweep.csv, sweep_blocks.csv, sweep.json, sweep.png.
struct SweepCommand {
  std::filesystem::path out_dir = "out";
  std::vector<double> forces;
  std::string axis;                // "" = from the scene's body force, else x
  std::vector<std::string> types;  // empty = the scene's body-force types, else every mobile one
  std::optional<double> fluid_density;
  std::optional<double> viscosity;  // given: no calibration
  std::optional<double> viscosity_error;
  std::string calibration = "small";      // tiny | small | full
  std::filesystem::path viscosity_cache;  // "" = default_viscosity_cache()
  SweepOptions run;                       // steady-state settings, simulation options
  // --warmup (--max-steps) not given: the warm-up from the sample's pores (sweep_warmup), and
  // max steps longer by what the warm-up grew.
  bool warmup_from_pores = false, max_steps_from_warmup = false;
  bool progress = true;
};

// The warm-up that lets a flow started from rest in a pore of diameter d (rc) become steady:
// in a slit of width d the slowest mode decays as exp(-pi^2 nu t / d^2) (in a tube, faster), so
// kWarmupRelaxations of those times, in steps of dt, rounded up to 100 steps, and never fewer
// than `least`. The median pore stands for the sample: with 3.5 the rule gives 8-11% more than
// the warm-ups the resolution study on real rock validated against the LBM (docs/accuracy.md:
// 2,880, 5,120 and 8,000 steps for median pores of 9.1, 12.1 and 15.1 rc: 3,200, 5,600, 8,700).
inline constexpr double kWarmupRelaxations = 3.5;
std::uint64_t viscous_warmup_steps(double pore_diameter, double kinematic_viscosity, double dt,
                                   std::uint64_t least);

// The median pore diameter (rc) that the scene's particle files record, if one does: `rockprep
// run` writes its block's pore sizes into the file's provenance ("pore_sizes": {"median_rc"}).
std::optional<double> median_pore_diameter_of(const Scene& scene);

// The warm-up of a sweep whose --warmup was not given (SweepCommand::warmup_from_pores): from the
// median pore and nu = mu / n_f, or the default when the sample records no pore sizes or
// options.viscosity is a stand-in (viscosity_known false: `rockflow relperm` without one). Sets
// options.warmup_steps (and max_steps), says so on stderr under `tool`'s name (with progress on),
// and returns the choice's record for the summary ("steady_state": {"warmup"}).
nlohmann::json sweep_warmup(const Scene& scene, const SweepCommand& command, SweepOptions& options,
                            const std::string& tool = "rockflow sweep",
                            bool viscosity_known = true);

// What a scene says about the fluid a sweep drives (shared with `rockflow relperm`). The driven
// types: --types, else the scene's body-force types, else every mobile one.
std::uint32_t driven_types_of(const Scene& scene, const SweepCommand& c, const std::string& where);
// The flow axis: --axis, else the axis of the driven types' largest body force.
int flow_axis_of(const Scene& scene, const SweepCommand& c, std::uint32_t driven);
// The fluid density the scene's [[init]] blocks (or its particle file's provenance) give the
// driven types, if any.
std::optional<double> density_from_scene(const Scene& scene, std::uint32_t driven);

// The steady-state settings and rule, as the summaries (sweep.json, relperm.json) record them.
nlohmann::json steady_state_json(const SweepOptions& options);

// Permeabilities in rc^2 and, with [units], in nm^2 and mD.
struct PermeabilityUnits {
  std::optional<sim::UnitSystem> units;
  double nm2 = 0, mD = 0;  // one rc^2 in nm^2 and in mD
  explicit PermeabilityUnits(const Scene& scene);
  nlohmann::json json(double k, double e) const;  // {rc2, rc2_error[, nm2.., mD..]}
};

// Runs the sweep a scene describes and writes the outputs; returns the summary (sweep.json).
nlohmann::json run_sweep_command(const Scene& scene, const SweepCommand& command);

}  // namespace mesorock::pipeline
