#include "voxel/volume.h"

#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <limits>
#include <sstream>

#include "mesorock/errors.h"

namespace mesorock::voxel {

const char* dtype_name(DType dtype) {
  switch (dtype) {
    case DType::kBool:
      return "bool";
    case DType::kInt8:
      return "int8";
    case DType::kUInt8:
      return "uint8";
    case DType::kUInt16:
      return "uint16";
    case DType::kFloat32:
      return "float32";
  }
  return "?";
}

std::size_t dtype_size(DType dtype) {
  switch (dtype) {
    case DType::kBool:
    case DType::kInt8:
    case DType::kUInt8:
      return 1;
    case DType::kUInt16:
      return 2;
    case DType::kFloat32:
      return 4;
  }
  return 1;
}

DType parse_dtype(const std::string& name) {
  if (name == "bool") return DType::kBool;
  if (name == "int8") return DType::kInt8;
  if (name == "uint8") return DType::kUInt8;
  if (name == "uint16") return DType::kUInt16;
  if (name == "float32") return DType::kFloat32;
  throw ConfigError("unknown dtype '" + name + "' (expected bool, int8, uint8, uint16 or float32)");
}

bool is_integer(DType dtype) {
  return dtype != DType::kFloat32;
}

std::string Shape::str() const {
  std::ostringstream s;
  s << nz << "x" << ny << "x" << nx;
  return s.str();
}

std::string Spacing::str() const {
  std::ostringstream s;
  s << dz << " x " << dy << " x " << dx << " " << unit;
  return s.str();
}

void validate_spacing(const Spacing& spacing, const std::string& where) {
  const std::string prefix = where.empty() ? "" : where + ": ";
  for (double d : {spacing.dz, spacing.dy, spacing.dx}) {
    if (!std::isfinite(d) || d <= 0) {
      throw ConfigError(prefix + "voxel spacing must be positive and finite, got " + spacing.str());
    }
  }
  if (spacing.unit.empty()) throw ConfigError(prefix + "voxel spacing needs a unit");
}

NonFiniteCounts count_non_finite(const Volume& volume) {
  NonFiniteCounts c;
  if (volume.dtype() != DType::kFloat32 || volume.empty()) return c;
  const float* v = volume.data<float>();
  const std::int64_t n = volume.voxels();
  for (std::int64_t i = 0; i < n; ++i) {
    if (std::isfinite(v[i])) continue;
    if (std::isnan(v[i])) {
      ++c.nan;
    } else if (v[i] > 0) {
      ++c.pos_inf;
    } else {
      ++c.neg_inf;
    }
  }
  return c;
}

std::string non_finite_note(const NonFiniteCounts& counts, std::int64_t voxels) {
  char share[32];
  std::snprintf(share, sizeof share, "%.3g%%",
                voxels > 0 ? 100.0 * static_cast<double>(counts.total()) / voxels : 0.0);
  return std::to_string(counts.total()) + " of " + std::to_string(voxels) + " voxels (" + share +
         ") are not finite numbers (" + std::to_string(counts.nan) + " NaN, " +
         std::to_string(counts.pos_inf) + " +inf, " + std::to_string(counts.neg_inf) +
         " -inf): they are read as no data; segment labels them outside (not pore, not solid; "
         "not counted in the porosity)";
}

std::size_t physical_memory_bytes() {
  const long pages = sysconf(_SC_PHYS_PAGES);
  const long page_size = sysconf(_SC_PAGE_SIZE);
  if (pages <= 0 || page_size <= 0) return std::numeric_limits<std::size_t>::max();
  return static_cast<std::size_t>(pages) * static_cast<std::size_t>(page_size);
}

std::size_t claimed_bytes(const Shape& shape, DType dtype, const std::string& what) {
  if (shape.nz <= 0 || shape.ny <= 0 || shape.nx <= 0) {
    throw IoError(what + ": shape " + shape.str() + " has an empty or negative axis");
  }
  // 2^62 bytes guards the products below against overflow before any comparison.
  constexpr std::int64_t kHuge = std::int64_t(1) << 62;
  const std::int64_t element = static_cast<std::int64_t>(dtype_size(dtype));
  if (shape.nx > kHuge / shape.ny || shape.nx * shape.ny > kHuge / shape.nz ||
      shape.voxels() > kHuge / element) {
    throw IoError(what + ": shape " + shape.str() + " is absurdly large");
  }
  return static_cast<std::size_t>(shape.voxels() * element);
}

std::size_t checked_volume_bytes(const Shape& shape, DType dtype, std::size_t max_bytes,
                                 const std::string& what) {
  const std::size_t bytes = claimed_bytes(shape, dtype, what);
  const std::size_t limit = max_bytes ? max_bytes : physical_memory_bytes();
  if (bytes > limit) {
    std::ostringstream s;
    s << what << ": shape " << shape.str() << " " << dtype_name(dtype) << " needs " << bytes
      << " bytes, more than the " << limit << " bytes of memory here";
    throw LimitError(s.str());
  }
  return bytes;
}

Volume::Volume(const Shape& shape, DType dtype, Spacing spacing)
    : shape_(shape), dtype_(dtype), spacing_(std::move(spacing)) {
  const std::size_t bytes = checked_volume_bytes(shape, dtype);
  // new[] without () leaves the bytes uninitialised: no page is touched until the loader writes.
  storage_.reset(new std::byte[bytes]);
}

void Volume::retag(DType dtype) {
  if (dtype_size(dtype) != dtype_size(dtype_)) {
    throw std::logic_error("Volume::retag: element sizes differ");
  }
  dtype_ = dtype;
}

double value_as_double(const Volume& volume, std::int64_t index) {
  return visit_dtype(volume.dtype(), [&](auto tag) -> double {
    using T = decltype(tag);
    return static_cast<double>(volume.data<T>()[index]);
  });
}

}  // namespace mesorock::voxel
