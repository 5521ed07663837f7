#pragma once
// Small PNG plots for reports: a line or bar chart with axes, ticks, numbers and titles.
//
// Why hand-written: a PNG is a signature, three chunks and a zlib stream (zlib is already a
// dependency), and the plots here are one series on linear axes. A plotting library (matplotlib
// needs Python at run time; PLplot or gnuplot are outside the dependency list) would be a large
// addition for two figures. Text uses a built-in 5x8 pixel font (ASCII letters, digits and common
// punctuation; other characters are drawn as '?').
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace mesorock::voxel {

// An RGB image, 8 bits per channel, row-major from the top.
struct Image {
  int width = 0;
  int height = 0;
  std::vector<std::uint8_t> rgb;  // width * height * 3
  Image(int w, int h, std::uint8_t grey = 255);
  void set(int x, int y, std::uint32_t colour);  // 0xRRGGBB; ignored outside the image
};

// Encodes as PNG (8-bit RGB, no interlace, zlib level 6). Throws IoError naming `display_name`.
void write_png(const Image& image, const std::filesystem::path& path,
               const std::string& display_name);
std::string encode_png(const Image& image);

enum class PlotStyle { kLine, kBars };

struct Plot {
  std::string title;
  std::string x_label;
  std::string y_label;
  PlotStyle style = PlotStyle::kLine;
  // Points (line) or bars: bar i spans [x[i], x[i] + bar_width) with height y[i].
  std::vector<double> x;
  std::vector<double> y;
  double bar_width = 0;
  bool y_from_zero = true;  // the y axis starts at 0 (else at the data's minimum)
  int width = 800;
  int height = 500;
};

// Renders the plot (axes with "nice" ticks, numbers, titles).
Image render_plot(const Plot& plot);
void write_plot_png(const Plot& plot, const std::filesystem::path& path,
                    const std::string& display_name);

}  // namespace mesorock::voxel
