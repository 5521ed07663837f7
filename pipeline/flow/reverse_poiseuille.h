#pragma once
// Shear viscosity of a one-type fluid by reverse Poiseuille flow (Backer et al. 2005): a body
// force +g x for z below the box's mid-plane and -g x above drives two opposite parabolic flows in
// a periodic box. In each half the steady Stokes equation eta u'' = -rho g s gives
// u = c0 + c1 z + c2 z^2, eta = -s rho g / (2 c2). One measurement for the `viscosity` validation
// case, the viscosity calibration of `rockflow sweep` and the viscosity column of `rockflow study`;
// each keeps its own binning and sampling (ReversePoiseuilleSampling), so each keeps its numbers.
#include <cstdint>
#include <functional>
#include <vector>

#include "pipeline/flow/systems.h"
#include "sim/simulation.h"

namespace mesorock::pipeline {

struct ReversePoiseuille {
  double eta = 0, eta_error = 0;
  double chi2_per_dof = 0;  // worse of the two halves' parabola fits
  double temperature = 0;   // mean bin temperature
  double u_max = 0;         // largest |mean velocity| of a bin
};

// Drives `model` for reverse Poiseuille flow: +g x on type 0 below the mid-plane along z, -g x
// above.
void drive_reverse_poiseuille(sim::Model& model, double g);

// eta from one reverse-Poiseuille velocity profile u (bins of `width` along the box, +g below the
// mid-plane, -g above): each half's parabola fit, the two averaged with weights 1/err^2. The worst
// half's chi^2 per dof goes to *worst_chi2 when given.
double reverse_poiseuille_eta(const std::vector<double>& u, const std::vector<double>& err,
                              double width, double rho, double g, double* worst_chi2);

// How the velocity profile is sampled: `bins` bins along z over the box, one sample every `every`
// steps, `blocks` consecutive blocks of `samples_per_block` samples.
struct ReversePoiseuilleSampling {
  int bins = 0;
  std::uint64_t every = 10;
  std::uint64_t blocks = 1, samples_per_block = 0;
};

// Called with each sample's bin sums before they are averaged (a caller's stability check: it
// throws to stop the measurement).
using ProfileSampleCheck = std::function<void(const std::vector<double>& sums)>;

// Samples the profile of a running simulation driven by drive_reverse_poiseuille in the periodic
// box `box`. eta comes from the whole run's profile (the halves' fits weighted by the bins' error
// bars; unit weights and no chi^2 while the profile has fewer than two blocks of its own), its
// error from the scatter of eta over the blocks, each fitted on its own (the bins of one profile
// are correlated, so a fit that treats them as independent underestimates the error).
ReversePoiseuille sample_reverse_poiseuille(sim::Simulation& sim, const sim::BoxSpec& box,
                                            const ReversePoiseuilleSampling& sampling, double rho,
                                            double g, const ProfileSampleCheck& check = {});

// The `viscosity` case's and the calibration's measurement: drives the periodic box of `s` (one
// type, type 0), runs `equilibrate` steps at dt = 0.01, then samples every 10 steps in 0.5 rc bins
// for `sample` steps in `blocks` blocks.
ReversePoiseuille measure_reverse_poiseuille(BuiltSystem s, double g, double rho,
                                             std::uint64_t equilibrate, std::uint64_t sample,
                                             int blocks, const sim::SimulationOptions& options);

}  // namespace mesorock::pipeline
