#pragma once
// Small PNG plots for reports: line, bar or point charts with axes, ticks, numbers, titles, error
// bars, several series and a legend. Used by rockprep (porosity profiles, pore sizes) and rockflow
// (permeability sweeps), which is why it lives in common/ (rockflow may not link voxel/).
//
// Why hand-written: a PNG is a signature, three chunks and a zlib stream (zlib is on every
// machine mesorock builds on, the GPU machine included), and the plots here are a few series on
// linear axes. A plotting library (matplotlib needs Python at run time; PLplot or gnuplot are
// outside the dependency list) would be a large addition for a few figures. Text uses a built-in
// 5x8 pixel font (ASCII letters, digits and common punctuation; other characters are drawn as
// '?').
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace mesorock::plot {

// An RGB image, 8 bits per channel, row-major from the top.
struct Image {
  int width = 0;
  int height = 0;
  std::vector<std::uint8_t> rgb;  // width * height * 3
  Image(int w, int h, std::uint8_t grey = 255);
  void set(int x, int y, std::uint32_t colour);  // 0xRRGGBB; ignored outside the image
};

// Encodes as PNG (8-bit RGB, no interlace, zlib level 6). write_png writes atomically (temporary
// file + rename) and throws IoError naming `display_name`.
void write_png(const Image& image, const std::filesystem::path& path,
               const std::string& display_name);
std::string encode_png(const Image& image);

enum class PlotStyle { kLine, kBars, kPoints };

// A further data set drawn over the main one (a fit, a reference curve), with a legend entry.
struct Series {
  std::string label;
  PlotStyle style = PlotStyle::kLine;
  std::vector<double> x, y;
  std::vector<double> y_error;  // error bars (points and lines); empty = none
  std::uint32_t colour = 0;     // 0xRRGGBB; 0 = the next colour of the palette
};

struct Plot {
  std::string title;
  std::string x_label;
  std::string y_label;
  PlotStyle style = PlotStyle::kLine;
  // Points (line, points) or bars: bar i spans [x[i], x[i] + bar_width) with height y[i].
  std::vector<double> x;
  std::vector<double> y;
  std::vector<double> y_error;  // error bars of the main series (line, points); empty = none
  std::string label;            // the main series' legend entry ("" = no legend)
  std::vector<Series> more;     // further series, drawn after the main one in this order
  double bar_width = 0;
  bool y_from_zero = true;   // the y axis starts at 0 (else at the data's minimum)
  bool x_from_zero = false;  // the x axis starts at 0 (else at the data's minimum)
  int width = 800;
  int height = 500;
};

// Renders the plot (axes with "nice" ticks, numbers, titles, legend).
Image render_plot(const Plot& plot);
void write_plot_png(const Plot& plot, const std::filesystem::path& path,
                    const std::string& display_name);

}  // namespace mesorock::plot
