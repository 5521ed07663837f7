#pragma once
// The lattice of the lattice Boltzmann reference: one node per pore voxel of a sim::SolidMask
// (periodic on all three axes), the pull table of D3Q19 links, and the percolating part of the
// pore space along the flow axis.
//
// Percolation: only pore components that connect to their own periodic image along the axis
// carry a steady flow (elsewhere the body force is balanced by pressure). Components are found
// with the links the LBM itself uses, 18-connectivity (faces and edges; two pore voxels that
// touch only at an edge are linked, voxels touching at a corner are not), on the periodic grid,
// tracking how many times a path wraps around the axis; a component percolates when it reaches
// a voxel with two different wrap counts. (A mask without solid has no wall to stop the flow:
// lbm_permeability refuses it. With any solid voxel, every pore component touches one: a
// component all of whose links lead to pore would be the whole periodic grid.)
#include <cstdint>
#include <string>
#include <vector>

#include "sim/solid_grid.h"

namespace mesorock::lbm {

struct Lattice {
  std::int64_t nodes = 0;
  std::vector<std::uint32_t> source;  // [(q - 1) * nodes + n]: node at x - c_q, or kWall
  std::vector<std::int64_t> voxel;    // [n]: the node's voxel index in the mask (image order)
};

// Throws LimitError (naming `what`) when `count` items of `bytes_each` exceed the memory this
// process may use (sim::host_memory_available: MemAvailable, the cgroup, RLIMIT_AS) or overflow.
void check_host_bytes(double count, double bytes_each, const std::string& what);

// The lattice of the percolating pore nodes of `mask` along `axis`, numbered in image order
// (z-major). Empty (nodes == 0) when nothing percolates. Throws LimitError when the nodes do not
// fit in memory or exceed 2^32 - 2.
Lattice percolating_lattice(const sim::SolidMask& mask, int axis, int threads);

// The same solid on a finer lattice: every voxel split into n^3 (voxel edges / n): the same
// staircase, resolved by more nodes. LimitError when the refined mask would exceed 2^33 voxels
// or the memory.
sim::SolidMask refine_mask(const sim::SolidMask& mask, int n);

}  // namespace mesorock::lbm
