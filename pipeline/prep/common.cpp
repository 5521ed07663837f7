#include "pipeline/prep/common.h"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>

#include "mesorock/errors.h"
#include "mesorock/version.h"
#include "voxel/npy_io.h"
#include "voxel/raw_io.h"
#include "voxel/segment.h"
#include "voxel/staged_output.h"
#include "voxel/tiff_io.h"

namespace mesorock::pipeline::prep {
namespace {
std::vector<std::string> g_command_line;
}

void set_command_line(int argc, char** argv) {
  g_command_line.assign(argv, argv + argc);
}
const std::vector<std::string>& command_line() {
  return g_command_line;
}

std::vector<double> parse_numbers(const std::string& text, const std::string& option) {
  std::vector<double> values;
  for (const std::string& part : voxel::split(text, ',')) {
    const std::string t = voxel::trim(part);
    char* end = nullptr;
    const double v = std::strtod(t.c_str(), &end);
    if (t.empty() || *end != '\0' || !std::isfinite(v)) {
      throw ConfigError(option + ": '" + text + "' is not a comma-separated list of numbers");
    }
    values.push_back(v);
  }
  return values;
}

voxel::Shape parse_shape(const std::string& text, const std::string& option) {
  const std::vector<double> v = parse_numbers(text, option);
  if (v.size() != 3) throw ConfigError(option + ": expected Z,Y,X, got '" + text + "'");
  for (double d : v) {
    if (d < 1 || d != std::floor(d) || d > 1e9) {
      throw ConfigError(option + ": '" + text + "' must be three positive integers");
    }
  }
  return {static_cast<std::int64_t>(v[0]), static_cast<std::int64_t>(v[1]),
          static_cast<std::int64_t>(v[2])};
}

void InputArgs::add_to(CLI::App* app) {
  app->add_option("input", path,
                  "Input: a folder of TIFF slices, a (multi-page) TIFF, .npy, .npz, HDF5 (.h5), "
                  ".mhd/.mha, or headerless raw (with --shape and --dtype)")
      ->required();
  app->add_option("--shape", shape, "Raw input: Z,Y,X (slowest axis first)");
  app->add_option("--dtype", dtype, "Raw input: bool, int8, uint8, uint16 or float32");
  app->add_option("--byte-order", byte_order, "Raw input: little (default) or big")
      ->check(CLI::IsMember({"little", "big"}));
  app->add_option("--header-bytes", header_bytes, "Raw input: bytes to skip at the start");
  app->add_option("--spacing", spacing,
                  "Voxel size DZ,DY,DX (overrides the file's metadata); needs --unit unless the "
                  "file gives one");
  app->add_option("--unit", unit, "Length unit of the spacing (nm, um, mm...)");
  app->add_option("--array", array, ".npz input: the array to read (default: the only one)");
  app->add_option("--dataset", dataset, "HDF5 input: the dataset path, e.g. /volume");
}

voxel::LoadOptions InputArgs::load_options() const {
  voxel::LoadOptions o;
  if (!shape.empty()) o.shape = parse_shape(shape, "--shape");
  if (!dtype.empty()) o.dtype = voxel::parse_dtype(dtype);
  o.big_endian = byte_order == "big";
  o.header_bytes = header_bytes;
  if (!spacing.empty()) {
    const std::vector<double> v = parse_numbers(spacing, "--spacing");
    if (v.size() != 3) throw ConfigError("--spacing: expected DZ,DY,DX, got '" + spacing + "'");
    if (unit.empty()) throw ConfigError("--spacing needs --unit (e.g. --unit nm)");
    voxel::Spacing s;
    s.dz = v[0];
    s.dy = v[1];
    s.dx = v[2];
    s.unit = voxel::normalize_unit(unit);
    voxel::validate_spacing(s, "--spacing");
    o.spacing = s;
  } else if (!unit.empty()) {
    o.unit = voxel::normalize_unit(unit);
  }
  o.array = array;
  o.dataset = dataset;
  return o;
}

void FilterArgs::add_to(CLI::App* app, bool with_fill) {
  app->add_option("--median", median,
                  "3-D median filter, window radius R or RZ,RY,RX in voxels (cube R=1: 3x3x3)");
  app->add_option("--median-shape", median_shape,
                  "Median window: cube (default) or ball (ellipsoid with the radii; e.g. "
                  "--median 0.75,1.5,1.5 --median-shape ball is the 3x3 in-plane square)")
      ->check(CLI::IsMember({"cube", "ball"}));
  app->add_option("--gaussian", gaussian, "Gaussian filter, sigma in voxels")
      ->check(CLI::Range(0.0, 100.0));
  app->add_flag("--gaussian-physical", gaussian_physical,
                "Gaussian sigma is in the spacing's unit (per-axis voxels for anisotropic data)");
  app->add_option("--fov", fov,
                  "Circular field of view: 'auto' (inscribed circle), 'value=V' (fit the voxels "
                  "not equal to the scanner's outside value V) or 'CX,CY,R' in voxels");
  if (with_fill) {
    app->add_option("--fov-fill", fov_fill, "Value written outside the field of view (default 0)");
  }
}

void Progress::note(const std::string& line) const {
  if (!quiet_) std::cout << "rockprep: " << line << std::endl;
}

void Progress::warn(const std::string& line) {
  warnings_.push_back(line);
  std::cerr << "rockprep: warning: " << line << std::endl;
}

void Progress::report(const std::string& what, std::int64_t voxels,
                      std::chrono::steady_clock::time_point start) const {
  if (quiet_) return;
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  char line[256];
  if (voxels > 0 && seconds > 0) {
    std::snprintf(line, sizeof line, " (%.3f s, %.1f Mvoxel/s)", seconds,
                  static_cast<double>(voxels) / seconds / 1e6);
  } else {
    std::snprintf(line, sizeof line, " (%.3f s)", seconds);
  }
  std::cout << "rockprep: " << what << line << std::endl;
}

voxel::Volume load_input(const InputArgs& input, Progress& progress, voxel::ReadReport* report) {
  const voxel::LoadOptions options = input.load_options();
  voxel::Volume volume;
  const auto start = std::chrono::steady_clock::now();
  volume = voxel::load_volume(input.path, options, report);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::ostringstream s;
  s << "load " << input.path << ": " << report->format << ", " << volume.shape().str() << " "
    << voxel::dtype_name(volume.dtype()) << ", spacing " << volume.spacing().str() << " ("
    << report->spacing_source << ")";
  char timing[128];
  std::snprintf(timing, sizeof timing, " (%.3f s, %.1f Mvoxel/s)", seconds,
                static_cast<double>(volume.voxels()) / std::max(seconds, 1e-9) / 1e6);
  progress.note(s.str() + timing);
  for (const std::string& w : report->warnings) progress.warn(w);
  return volume;
}

void LabelInputArgs::add_to(CLI::App* app) {
  input.add_to(app);
  app->add_option("--labels", labels,
                  "Phases of a volume labelled elsewhere: value=phase,... e.g. "
                  "'true=pore,false=solid' or '0=pore,255=solid' (not needed for rockprep's own "
                  "label files, whose sidecar gives the phase codes)");
}

bool has_phase_codes(const voxel::ReadReport& report) {
  return report.provenance.is_object() && report.provenance.contains("phase_codes");
}

voxel::Volume load_labels(const LabelInputArgs& args, Progress& progress, nlohmann::json* record) {
  InputArgs input = args.input;
  const std::filesystem::path as_folder(input.path);
  if (std::filesystem::is_directory(as_folder) &&
      std::filesystem::exists(as_folder / "labels.mhd")) {
    input.path = (as_folder / "labels.mhd").string();  // a segment output folder
  }
  // Parse the map before the (possibly long) load.
  const voxel::LabelMap map =
      args.labels.empty() ? voxel::LabelMap{} : voxel::LabelMap::parse(args.labels);
  voxel::ReadReport report;
  voxel::Volume volume = load_input(input, progress, &report);
  nlohmann::json in = input_record(input, volume, report);
  if (!args.labels.empty()) {
    const voxel::Spacing spacing = volume.spacing();
    volume = progress.stage("label by map " + map.str(), volume.voxels(), [&] {
      return about_file(input.path,
                        [&] { return voxel::segment_by_label_map(std::move(volume), map); });
    });
    volume.set_spacing(spacing);
    in["label_map"] = map.str();
  } else if (has_phase_codes(report)) {
    if (volume.dtype() != voxel::DType::kUInt8) {
      throw ConfigError(input.path + ": phase labels must be uint8, not " +
                        voxel::dtype_name(volume.dtype()));
    }
    in["phase_codes"] = report.provenance["phase_codes"];
  } else {
    throw ConfigError(input.path +
                      ": not a phase-label volume (no mesorock sidecar with phase codes); give "
                      "--labels VALUE=PHASE,... e.g. --labels 0=pore,255=solid");
  }
  if (record) *record = in;
  return volume;
}

void write_json(const std::filesystem::path& path, const nlohmann::json& record,
                const std::string& display_name) {
  std::ofstream s(path);
  s << record.dump(2) << "\n";
  s.close();
  if (!s) throw IoError(display_name + ": write failed");
}

void check_output_folder(const std::string& out) {
  namespace fs = std::filesystem;
  const fs::path p(out);
  // Missing parents are created, as users expect of --out (mkdir -p); a parent that is a file is
  // named. Only the folders: the outputs themselves are staged and renamed when complete.
  std::error_code ec;
  if (!p.parent_path().empty() && !fs::create_directories(p.parent_path(), ec) && ec) {
    for (fs::path q = p.parent_path(); !q.empty() && q != q.parent_path(); q = q.parent_path())
      if (fs::exists(q) && !fs::is_directory(q))
        throw IoError(out + ": " + q.string() + " is a file, not a folder");
    throw IoError(out + ": cannot create its parent folder: " + ec.message());
  }
  if (std::filesystem::exists(p) && !std::filesystem::is_directory(p)) {
    throw IoError(out + ": exists and is not a folder");
  }
}

nlohmann::json apply_filters(const FilterArgs& filters, voxel::Volume& volume, Progress& progress,
                             std::optional<voxel::FieldOfView>* fov_out) {
  nlohmann::json record = nlohmann::json::object();
  const std::int64_t n = volume.voxels();
  std::optional<voxel::FieldOfView> fov;
  if (!filters.fov.empty()) {
    if (filters.fov == "auto") {
      fov = voxel::inscribed_field_of_view(volume.shape());
    } else if (filters.fov.rfind("value=", 0) == 0) {
      const std::vector<double> v = parse_numbers(filters.fov.substr(6), "--fov value=");
      if (v.size() != 1) throw ConfigError("--fov value=V takes one number");
      fov = progress.stage("field of view from outside value", n,
                           [&] { return voxel::field_of_view_from_value(volume, v[0]); });
      record["fov_outside_value"] = v[0];
    } else {
      const std::vector<double> v = parse_numbers(filters.fov, "--fov");
      if (v.size() != 3 || v[2] <= 0) {
        throw ConfigError("--fov: expected auto, value=V or CX,CY,R with R > 0");
      }
      fov = voxel::FieldOfView{v[0], v[1], v[2]};
    }
    std::ostringstream s;
    s << "field of view: centre x " << fov->cx << ", y " << fov->cy << ", radius " << fov->radius
      << " voxels";
    progress.note(s.str());
    record["field_of_view"] = {{"cx", fov->cx}, {"cy", fov->cy}, {"radius", fov->radius}};
  }
  if (!filters.median.empty()) {
    const std::vector<double> r = parse_numbers(filters.median, "--median");
    if (r.size() != 1 && r.size() != 3) throw ConfigError("--median: expected R or RZ,RY,RX");
    voxel::MedianOptions m;
    m.radius_z = r.front();
    m.radius_y = r.size() == 3 ? r[1] : r.front();
    m.radius_x = r.size() == 3 ? r[2] : r.front();
    m.shape =
        filters.median_shape == "ball" ? voxel::MedianShape::kBall : voxel::MedianShape::kCube;
    std::int64_t window = 0;
    for (const voxel::MedianRow& row : voxel::median_window(m)) window += 2 * row.half_x + 1;
    progress.stage("median filter, " + filters.median_shape + " " + filters.median + " (" +
                       std::to_string(window) + " voxels)",
                   n, [&] { voxel::median_filter(volume, m); });
    record["median_window_voxels"] = window;
    record["median_radius_zyx"] = {m.radius_z, m.radius_y, m.radius_x};
    record["median_shape"] = filters.median_shape;
  }
  if (filters.gaussian > 0) {
    const voxel::GaussianOptions g =
        filters.gaussian_physical ? voxel::physical_gaussian(filters.gaussian, volume.spacing())
                                  : voxel::isotropic_gaussian(filters.gaussian);
    progress.stage("Gaussian filter", n, [&] { voxel::gaussian_filter(volume, g); });
    record["gaussian_sigma_voxels_zyx"] = {g.sigma_z, g.sigma_y, g.sigma_x};
  }
  if (fov_out) *fov_out = fov;
  return record;
}

void write_volume(const voxel::Volume& volume, const std::string& out, const nlohmann::json& record,
                  Progress& progress) {
  const std::filesystem::path target(out);
  const std::string ext = voxel::lowercase(target.extension().string());
  if (ext != ".mhd" && ext != ".tif" && ext != ".tiff" && ext != ".npy") {
    throw ConfigError(out + ": output must end in .mhd, .tif or .npy");
  }
  progress.stage("write " + out, volume.voxels(), [&] {
    voxel::StagedOutputs outputs = voxel::StagedOutputs::files();
    if (ext == ".mhd") {
      voxel::write_mhd(volume, outputs, target, record);
    } else {
      const std::filesystem::path data = outputs.stage(target);
      if (ext == ".npy") {
        voxel::write_npy(volume, data);
      } else {
        voxel::write_tiff_file(volume, data, {}, out);
      }
      nlohmann::json sidecar = record;
      sidecar["generator"] = "mesorock";
      sidecar["dtype"] = voxel::dtype_name(volume.dtype());
      sidecar["spacing_zyx"] = {volume.spacing().dz, volume.spacing().dy, volume.spacing().dx};
      sidecar["unit"] = volume.spacing().unit;
      const std::filesystem::path json = outputs.stage(voxel::sidecar_path(target));
      std::ofstream s(json);
      s << sidecar.dump(2) << "\n";
      if (!s) throw IoError(voxel::sidecar_path(target).string() + ": write failed");
    }
    outputs.commit();
  });
}

nlohmann::json provenance(const std::string& command) {
  return {{"tool", "rockprep"},
          {"command", command},
          {"mesorock_version", kVersion},
          {"git_commit", kGitCommit},
          {"command_line", command_line()}};
}

nlohmann::json input_record(const InputArgs& input, const voxel::Volume& volume,
                            const voxel::ReadReport& report) {
  const voxel::Spacing& s = volume.spacing();
  nlohmann::json j = {{"path", input.path},
                      {"format", report.format},
                      {"shape_zyx", {volume.shape().nz, volume.shape().ny, volume.shape().nx}},
                      {"dtype", voxel::dtype_name(volume.dtype())},
                      {"spacing_zyx", {s.dz, s.dy, s.dx}},
                      {"unit", s.unit},
                      {"spacing_source", report.spacing_source}};
  if (!input.array.empty()) j["array"] = input.array;
  if (!input.dataset.empty()) j["dataset"] = input.dataset;
  if (report.provenance.is_object()) j["provenance"] = report.provenance;
  if (report.non_finite.total() > 0)
    j["non_finite_voxels"] = {{"nan", report.non_finite.nan},
                              {"+inf", report.non_finite.pos_inf},
                              {"-inf", report.non_finite.neg_inf},
                              {"labelled", "outside (no data: not pore, not solid)"}};
  return j;
}

}  // namespace mesorock::pipeline::prep
