// rockprep synth: a synthetic three-phase shale-like stack with its ground-truth labels.
#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>

#include "mesorock/errors.h"
#include "pipeline/prep/common.h"
#include "voxel/raw_io.h"
#include "voxel/staged_output.h"
#include "voxel/synth.h"
#include "voxel/tiff_io.h"

namespace fs = std::filesystem;

namespace mesorock::pipeline::prep {
namespace {

struct SynthArgs {
  std::string shape = "128,128,128";
  double porosity = 0.10;
  double organic = 0.25;
  double blob = 12.0;
  double pore_radius = 0.0;
  double matrix_pores = 0.2;
  double noise = 20.0;
  double blur = 0.0;
  std::string grey = "40,100,180";
  std::string dtype = "uint8";
  std::string spacing = "5,2.5,2.5";
  std::string unit = "nm";
  std::uint64_t seed = 1;
  bool deflate = false;
  std::string out;
  bool quiet = false;
};

int run_synth(const SynthArgs& a) {
  voxel::ShaleOptions o;
  o.shape = parse_shape(a.shape, "--shape");
  o.porosity = a.porosity;
  o.organic_fraction = a.organic;
  o.blob_radius = a.blob;
  o.pore_radius = a.pore_radius;
  o.matrix_pore_share = a.matrix_pores;
  o.noise = a.noise;
  o.blur = a.blur;
  const std::vector<double> grey = parse_numbers(a.grey, "--grey");
  if (grey.size() != 3) throw ConfigError("--grey: expected PORE,ORGANIC,INORGANIC grey levels");
  o.grey = {grey[0], grey[1], grey[2]};
  o.dtype = voxel::parse_dtype(a.dtype);
  const std::vector<double> sp = parse_numbers(a.spacing, "--spacing");
  if (sp.size() != 3) throw ConfigError("--spacing: expected DZ,DY,DX");
  o.spacing = voxel::Spacing{sp[0], sp[1], sp[2], voxel::normalize_unit(a.unit)};
  o.seed = a.seed;
  const fs::path out(a.out);
  if (fs::exists(out) && !fs::is_directory(out))
    throw IoError(a.out + ": exists and is not a folder");
  if (fs::exists(out / "grey")) {
    throw IoError((out / "grey").string() +
                  ": already exists; remove it first (old slices would mix with new ones)");
  }

  Progress progress(a.quiet);
  const voxel::ShaleSample sample =
      progress.stage("synthesise " + o.shape.str() + " shale", o.shape.voxels(),
                     [&] { return voxel::make_shale(o); });
  const voxel::PhaseCounts& c = sample.truth_counts;
  std::ostringstream s;
  s.precision(4);
  s << "truth: porosity " << c.porosity() << " (pore " << c.fraction(voxel::Phase::kPore)
    << ", organic_pore " << c.fraction(voxel::Phase::kOrganicPore) << "), organic "
    << c.fraction(voxel::Phase::kOrganic) << ", inorganic " << c.fraction(voxel::Phase::kInorganic);
  progress.note(s.str());

  nlohmann::json record = provenance("synth");
  record["parameters"] = {
      {"shape_zyx", {o.shape.nz, o.shape.ny, o.shape.nx}},
      {"porosity", o.porosity},
      {"organic_fraction", o.organic_fraction},
      {"blob_radius_voxels", o.blob_radius},
      {"pore_radius_voxels", o.pore_radius > 0 ? o.pore_radius : o.blob_radius / 3},
      {"matrix_pore_share", o.matrix_pore_share},
      {"noise_grey_levels", o.noise},
      {"blur_voxels", o.blur},
      {"grey_pore_organic_inorganic", grey},
      {"dtype", a.dtype},
      {"spacing_zyx", sp},
      {"unit", o.spacing.unit},
      {"seed", o.seed}};
  nlohmann::json phases = nlohmann::json::object();
  for (int p = 1; p < voxel::kPhaseCount; ++p) {
    const auto phase = static_cast<voxel::Phase>(p);
    phases[voxel::phase_name(phase)] = {{"code", p},
                                        {"voxels", c.voxels[static_cast<std::size_t>(p)]},
                                        {"fraction", c.fraction(phase)}};
  }
  record["truth_phases"] = phases;
  record["truth_porosity"] = c.porosity();
  record["outputs"] = {"grey/slice_*.tif", "truth.mhd", "truth.raw", "truth.json", "synth.json"};

  progress.stage("write " + a.out, o.shape.voxels(), [&] {
    voxel::StagedOutputs outputs = voxel::StagedOutputs::in_directory(out);
    voxel::TiffWriteOptions tiff;
    tiff.deflate = a.deflate;
    voxel::write_tiff_slices(sample.grey, outputs, "grey", tiff);
    nlohmann::json truth_record = provenance("synth");
    truth_record["phase_codes"] = "0=outside,1=pore,2=organic,3=inorganic,4=organic_pore";
    voxel::write_mhd(sample.truth, outputs, "truth.mhd", truth_record);
    std::ofstream j(outputs.stage("synth.json"));
    j << record.dump(2) << "\n";
    j.close();
    if (!j) throw IoError((out / "synth.json").string() + ": write failed");
    outputs.commit();
  });
  return 0;
}

}  // namespace

Command add_synth_command(CLI::App& rockprep) {
  auto args = std::make_shared<SynthArgs>();
  CLI::App* app = rockprep.add_subcommand(
      "synth",
      "Make a synthetic shale-like grey stack (pores in organic matter in an inorganic matrix) "
      "as DIR/grey/slice_*.tif, with ground truth DIR/truth.mhd and DIR/synth.json");
  app->add_option("--shape", args->shape, "Z,Y,X (default 128,128,128)");
  app->add_option("--porosity", args->porosity, "Pore volume fraction (default 0.10)");
  app->add_option("--organic", args->organic,
                  "Organic matter volume fraction, its pores included (default 0.25)");
  app->add_option("--blob", args->blob, "Mean organic blob radius, voxels along x (default 12)");
  app->add_option("--pore-radius", args->pore_radius, "Mean pore radius (default blob / 3)");
  app->add_option("--matrix-pores", args->matrix_pores,
                  "Share of the pore volume in the inorganic matrix (default 0.2)");
  app->add_option("--noise", args->noise, "Gaussian noise std dev, grey levels 0-255 (default 20)");
  app->add_option("--blur", args->blur, "Point-spread sigma in voxels, before noise (default 0)");
  app->add_option("--grey", args->grey, "Mean grey of pore,organic,inorganic (default 40,100,180)");
  app->add_option("--dtype", args->dtype, "uint8 (default) or uint16");
  app->add_option("--spacing", args->spacing, "Voxel size DZ,DY,DX (default 5,2.5,2.5)");
  app->add_option("--unit", args->unit, "Unit of the spacing (default nm)");
  app->add_option("--seed", args->seed, "Random seed (default 1)");
  app->add_flag("--deflate", args->deflate, "Deflate-compress the TIFF slices");
  app->add_option("--out", args->out, "Output folder")->required();
  app->add_flag("--quiet", args->quiet, "No progress lines");
  return {app, [args] { return run_synth(*args); }};
}

}  // namespace mesorock::pipeline::prep
