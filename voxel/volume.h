#pragma once
// A dense 3-D image in memory: shape (nz, ny, nx) in C order (x fastest), a dtype tag, and the
// voxel spacing. Deliberately small: loaders, filters and segmentation all work on this one type.
#include <cstddef>
#include <cstdint>
#include <memory>
#include <stdexcept>
#include <string>
#include <type_traits>

namespace mesorock::voxel {

// The element types a rock image arrives in. kBool is stored as one byte per voxel holding 0 or 1.
enum class DType : std::uint8_t { kBool, kInt8, kUInt8, kUInt16, kFloat32 };

const char* dtype_name(DType dtype);         // "bool", "int8", "uint8", "uint16", "float32"
std::size_t dtype_size(DType dtype);         // bytes per voxel
DType parse_dtype(const std::string& name);  // throws ConfigError for an unknown name
bool is_integer(DType dtype);

// Storage type of each dtype, for templated kernels.
template <DType D>
struct StorageOf;
template <>
struct StorageOf<DType::kBool> {
  using type = std::uint8_t;
};
template <>
struct StorageOf<DType::kInt8> {
  using type = std::int8_t;
};
template <>
struct StorageOf<DType::kUInt8> {
  using type = std::uint8_t;
};
template <>
struct StorageOf<DType::kUInt16> {
  using type = std::uint16_t;
};
template <>
struct StorageOf<DType::kFloat32> {
  using type = float;
};

// Calls fn(T{}) with T the storage type of `dtype` (kBool and kUInt8 both give std::uint8_t).
template <class Fn>
decltype(auto) visit_dtype(DType dtype, Fn&& fn) {
  switch (dtype) {
    case DType::kBool:
    case DType::kUInt8:
      return fn(std::uint8_t{});
    case DType::kInt8:
      return fn(std::int8_t{});
    case DType::kUInt16:
      return fn(std::uint16_t{});
    case DType::kFloat32:
      return fn(float{});
  }
  throw std::logic_error("visit_dtype: bad dtype");
}

struct Shape {
  std::int64_t nz = 0;
  std::int64_t ny = 0;
  std::int64_t nx = 0;

  std::int64_t voxels() const { return nz * ny * nx; }
  std::int64_t slice_voxels() const { return ny * nx; }
  std::string str() const;  // "ZxYxX", the order the command line uses
  bool operator==(const Shape& o) const { return nz == o.nz && ny == o.ny && nx == o.nx; }
  bool operator!=(const Shape& o) const { return !(*this == o); }
};

// Voxel size along each axis, in `unit`. FIB-SEM stacks are often anisotropic (2.5 x 2.5 x 5 nm),
// so the three values are carried separately through every output.
struct Spacing {
  double dz = 1.0;
  double dy = 1.0;
  double dx = 1.0;
  std::string unit = "voxel";  // "voxel" means: no physical size is known

  bool known() const { return unit != "voxel"; }
  std::string str() const;  // "5 x 2.5 x 2.5 nm" (z, y, x)
};

// Throws ConfigError unless all three values are finite and positive and the unit is non-empty.
// `where` (the file and key, or the option, that gave the spacing) starts the message.
void validate_spacing(const Spacing& spacing, const std::string& where);

// Voxels of a float32 volume that are not finite numbers (none in an integer volume). Policy
// (docs/voxel.md): NaN and +-inf mean "no data" (a mask, an area the reconstruction did not
// cover); loading counts and reports them, and segmentation labels them outside: neither pore nor
// solid, left out of the porosity and the histogram.
struct NonFiniteCounts {
  std::int64_t nan = 0, pos_inf = 0, neg_inf = 0;
  std::int64_t total() const { return nan + pos_inf + neg_inf; }
};
// "12 of 1000 voxels (1.2%) are not finite numbers (10 NaN, 2 +inf, 0 -inf): they are read as no
// data; segment labels them outside (not pore, not solid; not counted in the porosity)".
std::string non_finite_note(const NonFiniteCounts& counts, std::int64_t voxels);

// Shape * dtype size. Throws IoError naming `what` when an axis is not positive or the product
// overflows: a header with such a shape is corrupt. Loaders compare this with the file size
// before anything is allocated.
std::size_t claimed_bytes(const Shape& shape, DType dtype, const std::string& what);
// claimed_bytes(), and throws LimitError when the result exceeds `max_bytes` (default: physical
// memory). The Volume constructor calls it.
std::size_t checked_volume_bytes(const Shape& shape, DType dtype, std::size_t max_bytes = 0,
                                 const std::string& what = "volume");
std::size_t physical_memory_bytes();

class Volume {
 public:
  Volume() = default;
  // Allocates without initialising (a 1024^3 volume is filled by the loader right after).
  Volume(const Shape& shape, DType dtype, Spacing spacing = {});

  const Shape& shape() const { return shape_; }
  DType dtype() const { return dtype_; }
  const Spacing& spacing() const { return spacing_; }
  void set_spacing(const Spacing& spacing) { spacing_ = spacing; }
  std::int64_t voxels() const { return shape_.voxels(); }
  std::size_t byte_size() const { return static_cast<std::size_t>(voxels()) * dtype_size(dtype_); }
  bool empty() const { return storage_ == nullptr; }

  std::byte* bytes() { return storage_.get(); }
  const std::byte* bytes() const { return storage_.get(); }

  // Typed access; T must be the storage type of dtype() (checked).
  template <class T>
  T* data() {
    check_type<T>();
    return reinterpret_cast<T*>(storage_.get());
  }
  template <class T>
  const T* data() const {
    check_type<T>();
    return reinterpret_cast<const T*>(storage_.get());
  }
  template <class T>
  T* slice(std::int64_t z) {
    return data<T>() + z * shape_.slice_voxels();
  }
  template <class T>
  const T* slice(std::int64_t z) const {
    return data<T>() + z * shape_.slice_voxels();
  }

  // Reinterprets the storage as another dtype of the same element size (e.g. uint8 grey values
  // overwritten in place by uint8 labels), so no second full-size buffer is needed.
  void retag(DType dtype);

 private:
  template <class T>
  void check_type() const {
    bool ok = false;
    visit_dtype(dtype_, [&](auto tag) { ok = std::is_same_v<decltype(tag), T>; });
    if (!ok)
      throw std::logic_error(std::string("Volume: wrong element type for ") + dtype_name(dtype_));
  }

  Shape shape_;
  DType dtype_ = DType::kUInt8;
  Spacing spacing_;
  std::unique_ptr<std::byte[]> storage_;
};

// Reads the value of voxel `index` as a double (for statistics and messages, not inner loops).
double value_as_double(const Volume& volume, std::int64_t index);

// The NaN and infinite voxels of a float32 volume (NonFiniteCounts above; zero otherwise).
NonFiniteCounts count_non_finite(const Volume& volume);

}  // namespace mesorock::voxel
