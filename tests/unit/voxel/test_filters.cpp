// Filters against straightforward reference implementations written independently here.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "mesorock/errors.h"
#include "test_util.h"
#include "voxel/filters.h"

namespace mesorock::voxel::test {
namespace {

// Is offset (dz, dy, dx) in the window? Decided here by the definition in filters.h.
bool in_window(const MedianOptions& o, int dz, int dy, int dx) {
  const double r[3] = {o.radius_z, o.radius_y, o.radius_x};
  const int d[3] = {dz, dy, dx};
  double sum = 0;
  for (int a = 0; a < 3; ++a) {
    if (r[a] == 0) {
      if (d[a] != 0) return false;
      continue;
    }
    if (o.shape == MedianShape::kCube && std::abs(d[a]) > r[a] + 1e-9) return false;
    sum += (d[a] / r[a]) * (d[a] / r[a]);
  }
  return o.shape == MedianShape::kCube || sum <= 1 + 1e-9;
}

// Median over the window clipped to the volume, lower middle for even counts: by sorting.
template <class T>
Volume reference_median(const Volume& in, const MedianOptions& o) {
  const Shape s = in.shape();
  Volume out(s, in.dtype());
  std::vector<T> w;
  for (std::int64_t z = 0; z < s.nz; ++z)
    for (std::int64_t y = 0; y < s.ny; ++y)
      for (std::int64_t x = 0; x < s.nx; ++x) {
        w.clear();
        for (int dz = -10; dz <= 10; ++dz)
          for (int dy = -10; dy <= 10; ++dy)
            for (int dx = -10; dx <= 10; ++dx) {
              const std::int64_t zz = z + dz, yy = y + dy, xx = x + dx;
              if (zz < 0 || zz >= s.nz || yy < 0 || yy >= s.ny || xx < 0 || xx >= s.nx) continue;
              if (in_window(o, dz, dy, dx)) w.push_back(in.data<T>()[(zz * s.ny + yy) * s.nx + xx]);
            }
        std::sort(w.begin(), w.end());
        out.data<T>()[(z * s.ny + y) * s.nx + x] = w[(w.size() - 1) / 2];
      }
  return out;
}

MedianOptions ball(double rz, double ry, double rx) {
  MedianOptions o;
  o.radius_z = rz;
  o.radius_y = ry;
  o.radius_x = rx;
  o.shape = MedianShape::kBall;
  return o;
}

TEST(Median, WindowSizes) {
  auto voxels = [](const MedianOptions& o) {
    int n = 0;
    for (const MedianRow& r : median_window(o)) n += 2 * r.half_x + 1;
    return n;
  };
  EXPECT_EQ(voxels(cube_median(1)), 27);
  EXPECT_EQ(voxels(cube_median(2)), 125);
  EXPECT_EQ(voxels(ball(1, 1, 1)), 7);
  EXPECT_EQ(voxels(ball(1.5, 1.5, 1.5)), 19);
  EXPECT_EQ(voxels(ball(0.75, 1.5, 1.5)), 9);
  EXPECT_EQ(voxels(ball(0, 1, 1)), 5);
  EXPECT_THROW(median_window(cube_median(0)), ConfigError);
}

TEST(Median, MatchesSortingReference) {
  struct Case {
    DType dtype;
    MedianOptions options;
    Shape shape;
  };
  for (const Case c :
       {Case{DType::kUInt8, cube_median(1), {7, 9, 11}},
        Case{DType::kUInt8, cube_median(2), {6, 8, 13}},
        Case{DType::kUInt8, ball(1.5, 1.5, 1.5), {6, 8, 13}},
        Case{DType::kUInt8, ball(0.75, 1.5, 1.5), {5, 8, 9}},
        Case{DType::kUInt8, ball(2, 1, 2.5), {6, 7, 9}},
        Case{DType::kInt8, cube_median(1), {5, 6, 7}}, Case{DType::kBool, ball(1, 1, 1), {5, 6, 7}},
        Case{DType::kUInt16, cube_median(1), {5, 7, 9}},
        Case{DType::kUInt16, ball(1.5, 1.5, 1.5), {5, 6, 7}},
        Case{DType::kFloat32, cube_median(1), {4, 6, 8}},
        Case{DType::kUInt8, cube_median(1), {1, 5, 9}},
        Case{DType::kUInt8, cube_median(3), {4, 1, 5}}}) {
    Volume v = random_volume(c.shape, c.dtype, 17);
    if (c.dtype == DType::kUInt8) {
      // Few distinct values too, so ties are exercised.
      for (std::int64_t i = 0; i < v.voxels(); i += 3) v.data<std::uint8_t>()[i] %= 4;
    }
    Volume expected = visit_dtype(
        c.dtype, [&](auto tag) { return reference_median<decltype(tag)>(v, c.options); });
    median_filter(v, c.options);
    EXPECT_TRUE(same_voxels(v, expected))
        << dtype_name(c.dtype) << " radii " << c.options.radius_z << "," << c.options.radius_y
        << "," << c.options.radius_x << " shape " << c.shape.str();
  }
}

TEST(Median, RemovesIsolatedSpeckle) {
  Volume v(Shape{5, 5, 5}, DType::kUInt8);
  std::fill(v.data<std::uint8_t>(), v.data<std::uint8_t>() + v.voxels(), 100);
  v.data<std::uint8_t>()[62] = 255;  // centre voxel
  median_filter(v);
  EXPECT_EQ(v.data<std::uint8_t>()[62], 100);
}

// scipy.ndimage "reflect" by its definition, then a full (non-separable) 3-D convolution in
// double precision with the outer-product kernel.
std::int64_t mirror(std::int64_t i, std::int64_t n) {
  while (i < 0 || i >= n) i = i < 0 ? -i - 1 : 2 * n - 1 - i;
  return i;
}
std::vector<double> reference_kernel(double sigma) {
  const int half = int(4.0 * sigma + 0.5);
  std::vector<double> k;
  double sum = 0;
  for (int i = -half; i <= half; ++i) {
    k.push_back(std::exp(-0.5 * i * i / (sigma * sigma)));
    sum += k.back();
  }
  for (double& w : k) w /= sum;
  return k;
}
template <class T>
std::vector<double> reference_gaussian(const Volume& in, double sz, double sy, double sx) {
  const Shape s = in.shape();
  const auto kz = reference_kernel(sz), ky = reference_kernel(sy), kx = reference_kernel(sx);
  const int hz = int(kz.size() / 2), hy = int(ky.size() / 2), hx = int(kx.size() / 2);
  std::vector<double> out(static_cast<std::size_t>(s.voxels()));
  for (std::int64_t z = 0; z < s.nz; ++z)
    for (std::int64_t y = 0; y < s.ny; ++y)
      for (std::int64_t x = 0; x < s.nx; ++x) {
        double acc = 0;
        for (int a = -hz; a <= hz; ++a)
          for (int b = -hy; b <= hy; ++b)
            for (int c = -hx; c <= hx; ++c) {
              const std::int64_t i =
                  (mirror(z + a, s.nz) * s.ny + mirror(y + b, s.ny)) * s.nx + mirror(x + c, s.nx);
              acc += kz[a + hz] * ky[b + hy] * kx[c + hx] * double(in.data<T>()[i]);
            }
        out[static_cast<std::size_t>((z * s.ny + y) * s.nx + x)] = acc;
      }
  return out;
}

TEST(Gaussian, Float32MatchesDirectConvolution) {
  const Volume original = random_volume({6, 7, 9}, DType::kFloat32, 5);
  Volume v = random_volume({6, 7, 9}, DType::kFloat32, 5);
  GaussianOptions o;
  o.sigma_z = 0.8;
  o.sigma_y = 1.0;
  o.sigma_x = 1.5;  // wider than half the x extent: mirrored more than once
  gaussian_filter(v, o);
  const std::vector<double> expected = reference_gaussian<float>(original, 0.8, 1.0, 1.5);
  double worst = 0;
  for (std::size_t i = 0; i < expected.size(); ++i) {
    worst = std::max(worst, std::abs(double(v.data<float>()[i]) - expected[i]));
  }
  EXPECT_LT(worst, 1e-3);  // values span +-1000
}

TEST(Gaussian, Uint8WithinOneGreyLevelOfExact) {
  const Volume original = random_volume({8, 9, 10}, DType::kUInt8, 9);
  Volume v = random_volume({8, 9, 10}, DType::kUInt8, 9);
  gaussian_filter(v, isotropic_gaussian(1.0));
  const std::vector<double> expected = reference_gaussian<std::uint8_t>(original, 1, 1, 1);
  double worst = 0;
  for (std::size_t i = 0; i < expected.size(); ++i) {
    worst = std::max(worst, std::abs(double(v.data<std::uint8_t>()[i]) - expected[i]));
  }
  EXPECT_LE(worst, 1.0);
}

TEST(Gaussian, KeepsConstantsAndRefusesBool) {
  Volume v(Shape{4, 5, 6}, DType::kUInt16);
  std::fill(v.data<std::uint16_t>(), v.data<std::uint16_t>() + v.voxels(), 1234);
  gaussian_filter(v, isotropic_gaussian(2.0));
  for (std::int64_t i = 0; i < v.voxels(); ++i) ASSERT_EQ(v.data<std::uint16_t>()[i], 1234);
  Volume b(Shape{2, 2, 2}, DType::kBool);
  EXPECT_THROW(gaussian_filter(b, isotropic_gaussian(1.0)), ConfigError);
  const GaussianOptions p = physical_gaussian(5.0, Spacing{5, 2.5, 2.5, "nm"});
  EXPECT_DOUBLE_EQ(p.sigma_z, 1.0);
  EXPECT_DOUBLE_EQ(p.sigma_y, 2.0);
  EXPECT_DOUBLE_EQ(p.sigma_x, 2.0);
}

TEST(FieldOfView, FitsADiskMarkedBySentinelAndMasksOutside) {
  const double cx = 40.3, cy = 30.7, r = 25.0;
  Volume v(Shape{2, 64, 80}, DType::kUInt16);
  std::int64_t outside = 0;
  for (std::int64_t z = 0; z < 2; ++z)
    for (std::int64_t y = 0; y < 64; ++y)
      for (std::int64_t x = 0; x < 80; ++x) {
        const bool in = (x - cx) * (x - cx) + (y - cy) * (y - cy) <= r * r;
        v.data<std::uint16_t>()[(z * 64 + y) * 80 + x] = in ? 500 : 1;
        outside += !in;
      }
  const FieldOfView fov = field_of_view_from_value(v, 1);
  EXPECT_NEAR(fov.cx, cx, 0.05);
  EXPECT_NEAR(fov.cy, cy, 0.05);
  EXPECT_NEAR(fov.radius, r, 0.1);
  const FieldOfView exact{cx, cy, r};
  EXPECT_EQ(apply_field_of_view(v, exact, 7), outside);
  for (std::int64_t i = 0; i < v.voxels(); ++i) {
    const std::uint16_t value = v.data<std::uint16_t>()[i];
    ASSERT_TRUE(value == 500 || value == 7);
  }
  EXPECT_THROW(apply_field_of_view(v, exact, 70000), ConfigError);
  const FieldOfView inscribed = inscribed_field_of_view(Shape{1, 64, 80});
  EXPECT_DOUBLE_EQ(inscribed.radius, 32);
  EXPECT_DOUBLE_EQ(inscribed.cx, 39.5);
}

}  // namespace
}  // namespace mesorock::voxel::test
