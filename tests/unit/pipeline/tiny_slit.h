#pragma once
// The tiny slit scene of the pipeline tests (`rockflow sweep`, `rockflow relperm`): water driven
// along x in a slit 5.5 rc wide over a lattice wall slab 1.5 rc thick with the wall model, about
// 800 particles.

namespace mesorock::test {

inline constexpr const char* kTinySlit = R"(name = "tiny-slit"
seed = 3
[box]
lo = [0.0, 0.0, 0.0]
hi = [4.0, 4.0, 7.0]
[model]
conservative = "mdpd"
[[types]]
name = "water"
body_force = [0.05, 0.0, 0.0]
[[types]]
name = "wall"
frozen = true
[[pairs]]
types = ["water", "water"]
A = -40.0
B = 25.0
gamma = 4.5
[[pairs]]
types = ["water", "wall"]
A = -40.0
B = 25.0
gamma = 4.5
[[pairs]]
types = ["wall", "wall"]
A = 0.0
B = 0.0
gamma = 0.0
[[init]]
kind = "lattice"
type = "wall"
density = 8.0
hi = [4.0, 4.0, 1.5]
[[init]]
kind = "random"
type = "water"
density = 7.0
lo = [0.0, 0.0, 1.5]
hi = [4.0, 4.0, 7.0]
[walls]
model = "li2018"
[[run]]
steps = 100
dt = 0.01
[units]
nm_per_rc = 0.852
)";

}  // namespace mesorock::test
