#pragma once
// What the studies of `rockflow study` (study.h) share: their sizes, the context they run in,
// the checks that call a run unstable, timing, and the form of a study's result. One file per
// study: study_accuracy.cpp (time step and precision), study_resolution.cpp, study_reorder.cpp,
// study_effects.cpp; study.cpp runs them and writes the outputs.
#include <chrono>
#include <cstdint>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "pipeline/flow/study.h"
#include "pipeline/flow/systems.h"
#include "pipeline/flow/validation.h"
#include "sim/simulation.h"

namespace mesorock::pipeline::study_detail {

using Clock = std::chrono::steady_clock;
using Json = nlohmann::ordered_json;

// A run is called unstable when its kinetic temperature leaves (0, kMaxTemperature) or a sampled
// value is not finite; the row then says so and the study goes on.
constexpr double kMaxTemperature = 3.0;
class Unstable : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};
// A run that blew up: the study's own checks (Unstable) or the solver's watchdog
// (NumericalError: NaN, infinity or a runaway particle). Either makes the row "unstable".
bool is_instability(const std::exception& e);

// Sizes of every study at one size (tiny / small / full).
struct Sizes {
  // Time step and precision.
  std::vector<double> dts{0.005, 0.01, 0.02, 0.03, 0.04};
  double pre_tau = 2;  // at dt = 0.01, once per system, before the per-dt runs
  double bulk_edge = 5, bulk_eq_tau = 1, bulk_sample_tau = 5;
  double visc_lxy = 5, visc_lz = 10, visc_rate = 0.2, visc_eq_tau = 1, visc_sample_tau = 8;
  double slit_width = 4, slit_lxy = 5, slit_rate = 0.2, slit_eq_tau = 1, slit_sample_tau = 8;
  std::uint64_t wall_equilibrate = 300;  // steps of the bulk liquid before the walls are cut
  std::uint64_t timed_steps = 50;        // pure stepping stretch on each accuracy system
  int scale_copies = 2;                  // the cost column: the bulk cube replicated n^3 times
  std::uint64_t scale_steps = 30;
  // Resolution.
  std::vector<double> widths{2, 3, 4, 6, 8};
  double res_pore_volume = 100;  // H * Lx * Ly per slit (Lx = Ly = sqrt(V / H), at least 3)
  double res_rate = 0.2, res_eq_tau = 1, res_sample_tau = 6;
  // Reorder interval, skin and cells per rc.
  std::vector<int> reorders{1, 2, 5, 10, 20};
  std::vector<double> skins{0.2, 0.5};
  std::vector<int> cells{2, 3};
  std::int64_t grid_particles = 4000;
  std::uint64_t grid_equilibrate = 60, grid_warm = 5, grid_steps = 30;
  double check_edge = 5;  // round-off check: a double-precision cube of the liquid
  std::uint64_t check_steps = 30;
  // Effects.
  int effect_cells = 2;  // porous benchmark, effect_cells x effect_cells cells of 16 x 2 x 16
  std::uint64_t effect_equilibrate = 60, effect_warm = 5, effect_steps = 30;
  int bare_repeats = 6;
};

Sizes sizes_for(StudySize size);

struct Context {
  StudyOptions o;
  Sizes z;
  ValidateOptions vo;  // for liquid_with_walls
};

// Progress on stderr, when verbose.
void say(const Context& c, const std::string& line);

std::uint64_t steps_for(double tau, double dt);
// Samples every 0.1 time units (to the nearest step), whatever the time step.
std::uint64_t sample_every(double dt);

// The kinetic temperature; Unstable when it is not finite or not below max_T.
double temperature_or_throw(sim::Simulation& s, const std::string& what,
                            double max_T = kMaxTemperature);

// Runs `steps` in chunks of about one time unit, checking the temperature after each. A system
// started from random positions is hot for its first steps: `max_T` infinite then checks only that
// the temperature stays finite.
void run_checked(sim::Simulation& s, std::uint64_t steps, const std::string& what,
                 double max_T = kMaxTemperature);

constexpr double kAnyTemperature = std::numeric_limits<double>::infinity();
// The speed studies only guard against a runaway: scenes without the thermostat drift in
// temperature.
constexpr double kRunawayTemperature = 10.0;

// Waits for the queued steps: a one-bin count that matches no type (a tiny kernel and a copy of
// 7 numbers on a device, where reading the temperature would copy every particle back).
void synchronise(sim::Simulation& s);

// A pure stretch of steps, timed from a synchronised start to a synchronised end; the temperature
// is checked afterwards. Returns million particle-steps per second.
double timed_mps(sim::Simulation& s, std::uint64_t steps, const std::string& what,
                 double max_T = kMaxTemperature);

// Nanoseconds of wall time per particle per simulated time unit at `mps` MPS/s and time step dt.
double ns_per_particle_tau(double mps, double dt);

Json number_or_null(double v);

// `s` after `steps` at dt = 0.01 (only a finite temperature checked).
BuiltSystem equilibrated(const Context& c, BuiltSystem s, std::uint64_t steps,
                         const std::string& what);

// What one study gives: its parameters, its rows (one CSV line each) and a summary.
struct StudyResult {
  Json parameters = Json::object();
  Json rows = Json::array();
  Json summary = Json::object();
  double seconds = 0;
};

// The studies, one file each.
void run_timestep_and_precision(const Context& c, bool want_dt, bool want_precision,
                                StudyResult& dt_study, StudyResult& precision_study);
StudyResult run_resolution(const Context& c);
StudyResult run_reorder(const Context& c);
StudyResult run_effects(const Context& c);

}  // namespace mesorock::pipeline::study_detail
