#pragma once
// Force terms as small functors with plain parameter structs (hoomd-blue Evaluator style), one
// file per term in sim/terms/. Each is __host__ __device__ and composed at compile time by the
// pass templates in sim/kernels.h. A term a scene does not ask for is an "Off" type whose members
// are constexpr false or empty: the compiler removes it together with its loads and arrays.
//
// A pair term also owns its parameters (host side): the [[pairs]] keys it reads (pair_keys,
// read_pair, with the scene's error messages), the key-forbidding note when another term of its
// kind is chosen (chosen_when), which model selects it (matches), its model check (check_pair)
// and its fields of the device table (fill_pair). sim/terms.h lists the terms and loops over them.
//
// Reduced units: rc = m = kBT = 1. r = |r_ij|, e = r_ij / r, r_ij = r_i - r_j, v_ij = v_i - v_j.
// Every pair term is zero for r >= rc = 1.
#include "sim/terms/body_force.h"
#include "sim/terms/conservative_dpd.h"
#include "sim/terms/conservative_mdpd.h"
#include "sim/terms/dpd_thermostat.h"
#include "sim/terms/pair_params.h"
