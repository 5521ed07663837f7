// rockflow study, the resolution study (docs/accuracy.md): the slit of study_accuracy.h at
// several widths.
#include <algorithm>
#include <cmath>

#include "pipeline/flow/statistics.h"
#include "pipeline/flow/study_accuracy.h"
#include "pipeline/flow/wall_liquid.h"

namespace mesorock::pipeline::study_detail {

using namespace wall_liquid;

// Study 4: slit width in rc (resolution) against the permeability's error from H^2 / 12.
StudyResult run_resolution(const Context& c) {
  StudyResult out;
  const auto t0 = Clock::now();
  out.parameters = {
      {"widths", c.z.widths},
      {"pore_volume_per_slit", c.z.res_pore_volume},
      {"wall_thickness", 1.5},
      {"peak_shear_rate", c.z.res_rate},
      {"dt", 0.01},
      {"precision", "double"},
      {"equilibrate_tau", c.z.res_eq_tau},
      {"sample_tau", c.z.res_sample_tau},
      {"viscosity", kBulkViscosity},
      {"hydrodynamic_wall", "the cut plane: where the frozen liquid ends and the fluid begins"}};
  std::uint64_t seed = c.o.seed + 40;
  for (double H : c.z.widths) {
    const double lxy = std::max(3.0, std::sqrt(c.z.res_pore_volume / H));
    const std::string what = "resolution H=" + fmt(H, 3);
    const auto t1 = Clock::now();
    const Prepared p = prepare_slit(c, H, lxy, c.z.res_rate, seed++);
    const SlitResult r =
        measure_slit(c, p, 0.01, sim::Precision::Double, c.z.res_eq_tau, c.z.res_sample_tau, what);
    const double stokes = H * H / 12;
    Json row;
    row["width"] = H;
    row["lxy"] = lxy;
    row["particles"] = p.s.particles.size();
    row["fluid_particles"] = p.fluid;
    row["fluid_density"] = p.fluid_density;
    row["g"] = p.g;
    row["stable"] = r.stable;
    row["mean_velocity"] = number_or_null(r.u_mean);
    row["mean_velocity_error"] = number_or_null(r.u_error);
    row["permeability"] = number_or_null(r.k);
    row["permeability_error"] = number_or_null(r.k_error);
    row["stokes_permeability"] = stokes;
    row["permeability_vs_stokes"] = number_or_null(r.k / stokes - 1);
    row["permeability_vs_stokes_error"] = number_or_null(r.k_error / stokes);
    row["hydrodynamic_width"] = number_or_null(r.hydrodynamic_width);
    row["slip_length"] = number_or_null(r.slip);
    row["wall_temperature"] = number_or_null(r.wall_temperature);
    row["bulk_temperature"] = number_or_null(r.bulk_temperature);
    row["mps"] = number_or_null(r.mps);
    row["seconds_per_tau"] = number_or_null(r.seconds_per_tau);
    // What a unit area of slit wall costs per time unit at this resolution (walls included).
    row["seconds_per_tau_per_area"] = number_or_null(r.seconds_per_tau / (lxy * lxy));
    row["ns_per_particle_tau"] = number_or_null(ns_per_particle_tau(r.mps, 0.01));
    row["failure"] = r.failure;
    out.rows.push_back(row);
    say(c, what + ": " + std::to_string(p.s.particles.size()) + " particles, k = " + fmt(r.k) +
               " +- " + fmt(r.k_error, 2) + " (H^2/12 = " + fmt(stokes) + "), slip " +
               fmt(r.slip, 3) + ", " + fmt(r.mps, 3) + " MPS/s (" + fmt(seconds_since(t1), 3) +
               " s)");
  }
  out.seconds = seconds_since(t0);
  return out;
}

}  // namespace mesorock::pipeline::study_detail
