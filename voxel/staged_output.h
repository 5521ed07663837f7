#pragma once
// StagedOutputs lives in common/ (rockflow's run outputs use it too); the voxel tools keep their
// name for it.
#include "mesorock/staged_outputs.h"

namespace mesorock::voxel {
using mesorock::StagedOutputs;
}  // namespace mesorock::voxel
