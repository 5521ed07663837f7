#pragma once
// Equations of state of the model's liquids, for set-ups and checks (no solver state).

namespace mesorock::sim {

// Warren's fit of the mDPD equation of state (P. B. Warren, Phys. Rev. E 68, 066702 (2003);
// docs/physics.md; the 2020 paper's Fig. 3b), for the Warren density kernel:
//   p = rho + alpha A rho^2 + 2 alpha B rd^4 (rho^3 - c rho^2 + d),  alpha = 0.101, c = 4.16, d
//   = 18.
// The eos-mdpd validation case checks the solver against it; the accuracy study and rockprep's
// flooding scenes (slab pressures) use it.
inline double warren_pressure(double rho, double A, double B, double rd) {
  constexpr double alpha = 0.101, c = 4.16, d = 18;
  const double rd4 = rd * rd * rd * rd;
  return rho + alpha * A * rho * rho + 2 * alpha * B * rd4 * (rho * rho * rho - c * rho * rho + d);
}

}  // namespace mesorock::sim
