// Regions of interest (crop by voxel or physical box), resampling, and the PNG plots.
#include <gtest/gtest.h>
#include <zlib.h>

#include "mesorock/errors.h"
#include "mesorock/plot.h"
#include "test_util.h"
#include "voxel/roi.h"

namespace mesorock::voxel::test {
namespace {

using mesorock::plot::encode_png;
using mesorock::plot::Image;
using mesorock::plot::Plot;
using mesorock::plot::PlotStyle;
using mesorock::plot::render_plot;

TEST(Roi, CropCopiesTheBox) {
  const Volume v = random_volume(Shape{7, 9, 11}, DType::kUInt16, 3);
  const VoxelBox box = parse_voxel_box("1:6, 2:9, 0:4", "--box");
  const Volume c = crop(v, box);
  ASSERT_EQ(c.shape(), (Shape{5, 7, 4}));
  for (int z = 0; z < 5; ++z)
    for (int y = 0; y < 7; ++y)
      for (int x = 0; x < 4; ++x)
        ASSERT_EQ(c.data<std::uint16_t>()[(z * 7 + y) * 4 + x],
                  v.data<std::uint16_t>()[((z + 1) * 9 + y + 2) * 11 + x]);
  EXPECT_THROW(crop(v, parse_voxel_box("0:8,0:9,0:11", "--box")), ConfigError);  // z too far
  EXPECT_THROW(crop(v, parse_voxel_box("-1:3,0:9,0:11", "--box")), ConfigError);
  EXPECT_THROW(crop(v, parse_voxel_box("3:3,0:9,0:11", "--box")), ConfigError);  // empty
  EXPECT_THROW(parse_voxel_box("0:1,0:1", "--box"), ConfigError);
  EXPECT_THROW(parse_voxel_box("0:1.5,0:1,0:1", "--box"), ConfigError);
  EXPECT_THROW(parse_voxel_box("0:a,0:1,0:1", "--box"), ConfigError);
}

TEST(Roi, PhysicalBoxTakesTheVoxelsWhoseCentresLieInIt) {
  const Shape shape{10, 20, 40};
  const Spacing s{5, 2.5, 2.5, "nm"};
  // z centres 2.5, 7.5, 12.5, ...: [5, 20) holds 7.5, 12.5, 17.5 -> voxels 1..3.
  // x centres 1.25, 3.75, ..., 11.25 (voxel 4): [10, 11.3) holds voxel 4 only.
  const VoxelBox b = voxels_in(parse_physical_box("5:20,0:50,10:11.3", "--physical-box"), shape, s);
  EXPECT_EQ(b.lo, (std::array<std::int64_t, 3>{1, 0, 4}));
  EXPECT_EQ(b.hi, (std::array<std::int64_t, 3>{4, 20, 5}));
  // Half-open: [10, 11.25) does not hold the centre 11.25.
  EXPECT_THROW(voxels_in(parse_physical_box("5:20,0:50,10:11.25", "p"), shape, s), ConfigError);
  EXPECT_THROW(voxels_in(parse_physical_box("0:60,0:10,0:10", "p"), shape, s), ConfigError);
  EXPECT_THROW(voxels_in(parse_physical_box("60:70,0:10,0:10", "p"), shape, s), ConfigError);
  EXPECT_THROW(voxels_in(parse_physical_box("7:5,0:10,0:10", "p"), shape, s), ConfigError);
}

TEST(Roi, ResampleNearestKeepsLabelsAndLinearInterpolates) {
  Volume v(Shape{4, 6, 8}, DType::kUInt8, Spacing{2, 1, 1, "um"});
  for (std::int64_t i = 0; i < v.voxels(); ++i) v.data<std::uint8_t>()[i] = std::uint8_t(i % 5);
  // Twice as fine: every output voxel copies the input voxel it lies in.
  ResampleOptions fine = zoom_grid(v.shape(), v.spacing(), {2, 2, 2});
  EXPECT_EQ(fine.shape, (Shape{8, 12, 16}));
  EXPECT_DOUBLE_EQ(fine.spacing.dz, 1.0);
  const Volume up = resample(v, fine);
  for (int z = 0; z < 8; ++z)
    for (int y = 0; y < 12; ++y)
      for (int x = 0; x < 16; ++x)
        ASSERT_EQ(up.data<std::uint8_t>()[(z * 12 + y) * 16 + x],
                  v.data<std::uint8_t>()[((z / 2) * 6 + y / 2) * 8 + x / 2]);
  // Back to the original grid gives the original labels.
  const Volume back = resample(up, spacing_grid(up.shape(), up.spacing(), {2, 1, 1}));
  EXPECT_TRUE(same_voxels(back, v));
  // Labels only ever take values present in the input.
  const Volume odd = resample(v, zoom_grid(v.shape(), v.spacing(), {0.7, 1.3, 0.45}));
  for (std::int64_t i = 0; i < odd.voxels(); ++i) ASSERT_LT(odd.data<std::uint8_t>()[i], 5);
  // Linear: a ramp along x stays a ramp.
  Volume ramp(Shape{1, 1, 4}, DType::kFloat32, Spacing{1, 1, 1, "um"});
  for (int x = 0; x < 4; ++x) ramp.data<float>()[x] = float(10 * x);
  ResampleOptions lin = zoom_grid(ramp.shape(), ramp.spacing(), {1, 1, 2});
  lin.interpolation = Interpolation::kLinear;
  const Volume r = resample(ramp, lin);
  // Output centres at input coordinates -0.25 (clamped to 0), 0.25, 0.75, ..., 3.25 (clamped).
  const float expect[8] = {0, 2.5, 7.5, 12.5, 17.5, 22.5, 27.5, 30};
  for (int x = 0; x < 8; ++x) EXPECT_FLOAT_EQ(r.data<float>()[x], expect[x]) << x;
  EXPECT_THROW(zoom_grid(v.shape(), v.spacing(), {0, 1, 1}), ConfigError);
  EXPECT_THROW(spacing_grid(v.shape(), v.spacing(), {1, -1, 1}), ConfigError);
  EXPECT_THROW(parse_interpolation("cubic"), ConfigError);
}

// Long y tick labels (a Darcy velocity of 1e-4: "0.00015") widen the left margin: between the
// vertical y label (columns 12-27) and the tick labels a band of columns stays blank.
TEST(Plot, LongTickLabelsDoNotRunIntoTheAxisLabel) {
  Plot plot;
  plot.y_label = "q  (rc / tau)";
  plot.x = {0.01, 0.02, 0.03};
  plot.y = {1.1e-4, 1.7e-4, 2.3e-4};
  const Image img = render_plot(plot);
  for (int x = 29; x < 38; ++x)
    for (int y = 0; y < img.height; ++y)
      for (int c = 0; c < 3; ++c)
        ASSERT_EQ(img.rgb[(static_cast<size_t>(y) * img.width + x) * 3 + c], 255)
            << "ink at column " << x << ", row " << y;
}

// Decodes our own PNGs with zlib: signature, chunk CRCs, IHDR, and the filtered rows.
TEST(Plot, PngIsValidAndDrawsTheData) {
  Plot plot;
  plot.title = "Porosity profile along z";
  plot.x_label = "z (nm)";
  plot.y_label = "porosity";
  plot.x = {0, 1, 2, 3};
  plot.y = {0.1, 0.3, 0.2, 0.25};
  plot.width = 320;
  plot.height = 200;
  const std::string png = encode_png(render_plot(plot));
  ASSERT_EQ(png.substr(0, 8), std::string("\x89PNG\r\n\x1a\n", 8));
  std::size_t pos = 8;
  std::string idat;
  std::uint32_t width = 0, height = 0;
  auto u32 = [&](std::size_t at) {
    return (std::uint32_t(std::uint8_t(png[at])) << 24) |
           (std::uint32_t(std::uint8_t(png[at + 1])) << 16) |
           (std::uint32_t(std::uint8_t(png[at + 2])) << 8) |
           std::uint32_t(std::uint8_t(png[at + 3]));
  };
  std::vector<std::string> types;
  while (pos < png.size()) {
    const std::uint32_t len = u32(pos);
    const std::string type = png.substr(pos + 4, 4);
    types.push_back(type);
    const std::uint32_t crc = static_cast<std::uint32_t>(
        crc32(0, reinterpret_cast<const Bytef*>(png.data() + pos + 4), len + 4));
    EXPECT_EQ(crc, u32(pos + 8 + len)) << type;
    if (type == "IHDR") {
      width = u32(pos + 8);
      height = u32(pos + 12);
      EXPECT_EQ(png[pos + 16], 8);  // bit depth
      EXPECT_EQ(png[pos + 17], 2);  // RGB
    }
    if (type == "IDAT") idat += png.substr(pos + 8, len);
    pos += 12 + len;
  }
  EXPECT_EQ(types, (std::vector<std::string>{"IHDR", "IDAT", "IEND"}));
  ASSERT_EQ(width, 320u);
  ASSERT_EQ(height, 200u);
  std::string raw((width * 3 + 1) * height, '\0');
  uLongf size = static_cast<uLongf>(raw.size());
  ASSERT_EQ(
      uncompress(reinterpret_cast<Bytef*>(raw.data()), &size,
                 reinterpret_cast<const Bytef*>(idat.data()), static_cast<uLong>(idat.size())),
      Z_OK);
  ASSERT_EQ(size, raw.size());
  std::int64_t blue = 0, black = 0;
  for (std::uint32_t y = 0; y < height; ++y) {
    ASSERT_EQ(raw[y * (width * 3 + 1)], 0);  // filter none
    for (std::uint32_t x = 0; x < width; ++x) {
      const auto* px =
          reinterpret_cast<const unsigned char*>(&raw[y * (width * 3 + 1) + 1 + 3 * x]);
      blue += px[0] == 0x1F && px[1] == 0x5F && px[2] == 0xA8;
      black += px[0] == 0 && px[1] == 0 && px[2] == 0;
    }
  }
  EXPECT_GT(blue, 200);   // the line
  EXPECT_GT(black, 500);  // axes and text
  // Bars.
  plot.style = PlotStyle::kBars;
  plot.bar_width = 1;
  const Image bars = render_plot(plot);
  EXPECT_EQ(bars.width, 320);
}

}  // namespace
}  // namespace mesorock::voxel::test
