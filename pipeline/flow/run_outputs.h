#pragma once
// The outputs of `rockflow run` (docs/scene.md, [output]) as RunOutputs of the run library
// (pipeline/flow/runner.h). Each is built only when the scene asks for it (or its model has the
// feature it reports) and owns its files:
// - ThermoOutput: thermo.csv; the averaged scalars and the leak invariant in the summary
// - SlabOutput: slabs.csv (rigid slabs); InjectionOutput: injection.csv
// - BalanceOutput: balance.csv (decomposed runs)
// - SnapshotOutput: snapshots/step_N.h5 + .xmf; FinalSnapshotOutput: final.h5 + .xmf
// - BinnedOutput: a profile or the fields (time-averaged)
// - RegionsOutput: regions.csv, saturation.csv, region_pressure.csv
#include <memory>
#include <vector>

#include "pipeline/flow/runner.h"

namespace mesorock::pipeline {

// The outputs a scene asks for, in the order they sample at a step (the order of the rows and of
// the collective calls of a decomposed run).
std::vector<std::unique_ptr<RunOutput>> make_scene_outputs(RunContext& run);

}  // namespace mesorock::pipeline
