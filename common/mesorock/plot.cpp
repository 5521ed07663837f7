#include "mesorock/plot.h"

#include <zlib.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <fstream>

#include "mesorock/atomic_file.h"
#include "mesorock/errors.h"

namespace mesorock::plot {
namespace {

// 5x8 pixel glyphs, one byte per column, bit 0 the top row (the classic "glcdfont" layout; the
// descenders of g, j, p, q, y use the eighth row).
struct Glyph {
  char c;
  std::array<std::uint8_t, 5> columns;
};
constexpr Glyph kFont[] = {
    {' ', {0x00, 0x00, 0x00, 0x00, 0x00}},  {'!', {0x00, 0x00, 0x5F, 0x00, 0x00}},
    {'#', {0x14, 0x7F, 0x14, 0x7F, 0x14}},  {'%', {0x23, 0x13, 0x08, 0x64, 0x62}},
    {'\'', {0x00, 0x05, 0x03, 0x00, 0x00}}, {'(', {0x00, 0x1C, 0x22, 0x41, 0x00}},
    {')', {0x00, 0x41, 0x22, 0x1C, 0x00}},  {'*', {0x14, 0x08, 0x3E, 0x08, 0x14}},
    {'+', {0x08, 0x08, 0x3E, 0x08, 0x08}},  {',', {0x00, 0x50, 0x30, 0x00, 0x00}},
    {'-', {0x08, 0x08, 0x08, 0x08, 0x08}},  {'.', {0x00, 0x60, 0x60, 0x00, 0x00}},
    {'/', {0x20, 0x10, 0x08, 0x04, 0x02}},  {'0', {0x3E, 0x51, 0x49, 0x45, 0x3E}},
    {'1', {0x00, 0x42, 0x7F, 0x40, 0x00}},  {'2', {0x42, 0x61, 0x51, 0x49, 0x46}},
    {'3', {0x21, 0x41, 0x45, 0x4B, 0x31}},  {'4', {0x18, 0x14, 0x12, 0x7F, 0x10}},
    {'5', {0x27, 0x45, 0x45, 0x45, 0x39}},  {'6', {0x3C, 0x4A, 0x49, 0x49, 0x30}},
    {'7', {0x01, 0x71, 0x09, 0x05, 0x03}},  {'8', {0x36, 0x49, 0x49, 0x49, 0x36}},
    {'9', {0x06, 0x49, 0x49, 0x29, 0x1E}},  {':', {0x00, 0x36, 0x36, 0x00, 0x00}},
    {'<', {0x08, 0x14, 0x22, 0x41, 0x00}},  {'=', {0x14, 0x14, 0x14, 0x14, 0x14}},
    {'>', {0x00, 0x41, 0x22, 0x14, 0x08}},  {'?', {0x02, 0x01, 0x51, 0x09, 0x06}},
    {'A', {0x7E, 0x11, 0x11, 0x11, 0x7E}},  {'B', {0x7F, 0x49, 0x49, 0x49, 0x36}},
    {'C', {0x3E, 0x41, 0x41, 0x41, 0x22}},  {'D', {0x7F, 0x41, 0x41, 0x22, 0x1C}},
    {'E', {0x7F, 0x49, 0x49, 0x49, 0x41}},  {'F', {0x7F, 0x09, 0x09, 0x09, 0x01}},
    {'G', {0x3E, 0x41, 0x49, 0x49, 0x7A}},  {'H', {0x7F, 0x08, 0x08, 0x08, 0x7F}},
    {'I', {0x00, 0x41, 0x7F, 0x41, 0x00}},  {'J', {0x20, 0x40, 0x41, 0x3F, 0x01}},
    {'K', {0x7F, 0x08, 0x14, 0x22, 0x41}},  {'L', {0x7F, 0x40, 0x40, 0x40, 0x40}},
    {'M', {0x7F, 0x02, 0x0C, 0x02, 0x7F}},  {'N', {0x7F, 0x04, 0x08, 0x10, 0x7F}},
    {'O', {0x3E, 0x41, 0x41, 0x41, 0x3E}},  {'P', {0x7F, 0x09, 0x09, 0x09, 0x06}},
    {'Q', {0x3E, 0x41, 0x51, 0x21, 0x5E}},  {'R', {0x7F, 0x09, 0x19, 0x29, 0x46}},
    {'S', {0x46, 0x49, 0x49, 0x49, 0x31}},  {'T', {0x01, 0x01, 0x7F, 0x01, 0x01}},
    {'U', {0x3F, 0x40, 0x40, 0x40, 0x3F}},  {'V', {0x1F, 0x20, 0x40, 0x20, 0x1F}},
    {'W', {0x3F, 0x40, 0x38, 0x40, 0x3F}},  {'X', {0x63, 0x14, 0x08, 0x14, 0x63}},
    {'Y', {0x07, 0x08, 0x70, 0x08, 0x07}},  {'Z', {0x61, 0x51, 0x49, 0x45, 0x43}},
    {'[', {0x00, 0x7F, 0x41, 0x41, 0x00}},  {']', {0x00, 0x41, 0x41, 0x7F, 0x00}},
    {'^', {0x04, 0x02, 0x01, 0x02, 0x04}},  {'_', {0x40, 0x40, 0x40, 0x40, 0x40}},
    {'a', {0x20, 0x54, 0x54, 0x54, 0x78}},  {'b', {0x7F, 0x48, 0x44, 0x44, 0x38}},
    {'c', {0x38, 0x44, 0x44, 0x44, 0x20}},  {'d', {0x38, 0x44, 0x44, 0x48, 0x7F}},
    {'e', {0x38, 0x54, 0x54, 0x54, 0x18}},  {'f', {0x08, 0x7E, 0x09, 0x01, 0x02}},
    {'g', {0x18, 0xA4, 0xA4, 0xA4, 0x7C}},  {'h', {0x7F, 0x08, 0x04, 0x04, 0x78}},
    {'i', {0x00, 0x44, 0x7D, 0x40, 0x00}},  {'j', {0x40, 0x80, 0x84, 0x7D, 0x00}},
    {'k', {0x7F, 0x10, 0x28, 0x44, 0x00}},  {'l', {0x00, 0x41, 0x7F, 0x40, 0x00}},
    {'m', {0x7C, 0x04, 0x18, 0x04, 0x78}},  {'n', {0x7C, 0x08, 0x04, 0x04, 0x78}},
    {'o', {0x38, 0x44, 0x44, 0x44, 0x38}},  {'p', {0xFC, 0x24, 0x24, 0x24, 0x18}},
    {'q', {0x18, 0x24, 0x24, 0x24, 0xFC}},  {'r', {0x7C, 0x08, 0x04, 0x04, 0x08}},
    {'s', {0x48, 0x54, 0x54, 0x54, 0x20}},  {'t', {0x04, 0x3F, 0x44, 0x40, 0x20}},
    {'u', {0x3C, 0x40, 0x40, 0x20, 0x7C}},  {'v', {0x1C, 0x20, 0x40, 0x20, 0x1C}},
    {'w', {0x3C, 0x40, 0x30, 0x40, 0x3C}},  {'x', {0x44, 0x28, 0x10, 0x28, 0x44}},
    {'y', {0x1C, 0xA0, 0xA0, 0xA0, 0x7C}},  {'z', {0x44, 0x64, 0x54, 0x4C, 0x44}},
};

const Glyph* glyph_of(char c) {
  for (const Glyph& g : kFont) {
    if (g.c == c) return &g;
  }
  return &kFont[27];  // '?'
}

constexpr std::uint32_t kBlack = 0x000000, kGrey = 0xC8C8C8, kBlue = 0x1F5FA8;
// Colours of further series, in order.
constexpr std::uint32_t kPalette[] = {0xC0392B, 0x27AE60, 0xE67E22, 0x8E44AD, 0x7F8C8D};

constexpr int kTextScale = 2;
constexpr int kAdvance = 6 * kTextScale;  // 5 columns and a gap

int text_width(const std::string& text) {
  return static_cast<int>(text.size()) * kAdvance - kTextScale;
}

// Draws `text` with its top-left corner at (x, y); vertical text reads bottom to top with its
// first character at (x, y) being the bottom-left corner.
void draw_text(Image& img, int x, int y, const std::string& text, std::uint32_t colour,
               bool vertical = false) {
  for (std::size_t k = 0; k < text.size(); ++k) {
    const Glyph* g = glyph_of(text[k]);
    for (int col = 0; col < 5; ++col) {
      for (int row = 0; row < 8; ++row) {
        if (!(g->columns[static_cast<std::size_t>(col)] & (1u << row))) continue;
        for (int sy = 0; sy < kTextScale; ++sy) {
          for (int sx = 0; sx < kTextScale; ++sx) {
            const int gx = static_cast<int>(k) * kAdvance + col * kTextScale + sx;
            const int gy = row * kTextScale + sy;
            if (vertical) {
              img.set(x + gy, y - gx, colour);
            } else {
              img.set(x + gx, y + gy, colour);
            }
          }
        }
      }
    }
  }
}

void fill_rect(Image& img, int x0, int y0, int x1, int y1, std::uint32_t colour) {
  for (int y = std::min(y0, y1); y <= std::max(y0, y1); ++y) {
    for (int x = std::min(x0, x1); x <= std::max(x0, x1); ++x) img.set(x, y, colour);
  }
}

// A line of width 2 (Bresenham, each point widened).
void draw_line(Image& img, int x0, int y0, int x1, int y1, std::uint32_t colour) {
  const int dx = std::abs(x1 - x0), sx = x0 < x1 ? 1 : -1;
  const int dy = -std::abs(y1 - y0), sy = y0 < y1 ? 1 : -1;
  int err = dx + dy;
  while (true) {
    fill_rect(img, x0, y0, x0 + 1, y0 + 1, colour);
    if (x0 == x1 && y0 == y1) break;
    const int e2 = 2 * err;
    if (e2 >= dy) {
      err += dy;
      x0 += sx;
    }
    if (e2 <= dx) {
      err += dx;
      y0 += sy;
    }
  }
}

// Ticks at 1, 2 or 5 x 10^k spacing, about `target` of them in [lo, hi].
std::vector<double> nice_ticks(double lo, double hi, int target = 6) {
  std::vector<double> ticks;
  if (!(hi > lo)) return {lo};
  const double raw = (hi - lo) / target;
  const double mag = std::pow(10.0, std::floor(std::log10(raw)));
  double step = mag;
  for (double m : {1.0, 2.0, 5.0, 10.0}) {
    if (m * mag >= raw) {
      step = m * mag;
      break;
    }
  }
  for (double t = std::ceil(lo / step - 1e-9) * step; t <= hi + step * 1e-9; t += step) {
    ticks.push_back(std::fabs(t) < step * 1e-9 ? 0.0 : t);
  }
  return ticks;
}

std::string tick_label(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.4g", v);
  return buf;
}

void png_chunk(std::string& out, const char* type, const std::string& data) {
  auto u32 = [&](std::uint32_t v) {
    for (int s = 24; s >= 0; s -= 8) out.push_back(static_cast<char>((v >> s) & 0xFF));
  };
  u32(static_cast<std::uint32_t>(data.size()));
  const std::string body = std::string(type, 4) + data;
  out += body;
  u32(static_cast<std::uint32_t>(
      crc32(0, reinterpret_cast<const Bytef*>(body.data()), static_cast<uInt>(body.size()))));
}

}  // namespace

Image::Image(int w, int h, std::uint8_t grey)
    : width(w),
      height(h),
      rgb(static_cast<std::size_t>(w) * static_cast<std::size_t>(h) * 3, grey) {}

void Image::set(int x, int y, std::uint32_t colour) {
  if (x < 0 || y < 0 || x >= width || y >= height) return;
  const std::size_t i = (static_cast<std::size_t>(y) * static_cast<std::size_t>(width) +
                         static_cast<std::size_t>(x)) *
                        3;
  rgb[i] = static_cast<std::uint8_t>(colour >> 16);
  rgb[i + 1] = static_cast<std::uint8_t>(colour >> 8);
  rgb[i + 2] = static_cast<std::uint8_t>(colour);
}

std::string encode_png(const Image& image) {
  std::string raw;
  const std::size_t row = static_cast<std::size_t>(image.width) * 3;
  raw.reserve((row + 1) * static_cast<std::size_t>(image.height));
  for (int y = 0; y < image.height; ++y) {
    raw.push_back('\0');  // filter type 0 (none)
    raw.append(reinterpret_cast<const char*>(image.rgb.data()) + static_cast<std::size_t>(y) * row,
               row);
  }
  uLongf size = compressBound(static_cast<uLong>(raw.size()));
  std::string z(size, '\0');
  if (compress2(reinterpret_cast<Bytef*>(z.data()), &size,
                reinterpret_cast<const Bytef*>(raw.data()), static_cast<uLong>(raw.size()),
                6) != Z_OK) {
    throw IoError("PNG: zlib compression failed");
  }
  z.resize(size);
  std::string out = "\x89PNG\r\n\x1a\n";
  std::string ihdr;
  for (std::uint32_t v :
       {static_cast<std::uint32_t>(image.width), static_cast<std::uint32_t>(image.height)}) {
    for (int s = 24; s >= 0; s -= 8) ihdr.push_back(static_cast<char>((v >> s) & 0xFF));
  }
  ihdr += std::string("\x08\x02\x00\x00\x00", 5);  // 8 bits, RGB, deflate, no filter, no interlace
  png_chunk(out, "IHDR", ihdr);
  png_chunk(out, "IDAT", z);
  png_chunk(out, "IEND", "");
  return out;
}

void write_png(const Image& image, const std::filesystem::path& path,
               const std::string& display_name) {
  const std::string bytes = encode_png(image);
  write_atomically(path, [&](const std::filesystem::path& tmp) {
    std::ofstream out(tmp, std::ios::binary);
    out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    out.close();
    if (!out) throw IoError(display_name + ": cannot write PNG");
  });
}

// A point marker (a filled square) and its error bar with caps.
void draw_point(Image& img, int x, int y, std::uint32_t colour) {
  fill_rect(img, x - 3, y - 3, x + 3, y + 3, colour);
}
void draw_error_bar(Image& img, int x, int y_lo, int y_hi, std::uint32_t colour) {
  fill_rect(img, x, std::min(y_lo, y_hi), x, std::max(y_lo, y_hi), colour);
  fill_rect(img, x - 4, y_lo, x + 4, y_lo, colour);
  fill_rect(img, x - 4, y_hi, x + 4, y_hi, colour);
}

Image render_plot(const Plot& plot) {
  Image img(plot.width, plot.height);
  const int right = 30, top = 50, bottom = 75;
  const int x1 = plot.width - right, y0 = plot.height - bottom, y1 = top;
  // Every series as one list: the main one first.
  Series main;
  main.label = plot.label;
  main.style = plot.style;
  main.x = plot.x;
  main.y = plot.y;
  main.y_error = plot.y_error;
  main.colour = kBlue;
  std::vector<Series> all = {main};
  for (std::size_t k = 0; k < plot.more.size(); ++k) {
    all.push_back(plot.more[k]);
    if (all.back().colour == 0)
      all.back().colour = kPalette[k % (sizeof kPalette / sizeof *kPalette)];
  }
  // Data ranges over every series, error bars included.
  double xmin = 0, xmax = 1, ymin = 0, ymax = 1;
  bool any = false;
  for (const Series& s : all) {
    for (std::size_t i = 0; i < s.x.size() && i < s.y.size(); ++i) {
      const double e = i < s.y_error.size() ? std::fabs(s.y_error[i]) : 0.0;
      const double xr = s.x[i] + (s.style == PlotStyle::kBars ? plot.bar_width : 0.0);
      if (!any) {
        xmin = s.x[i], xmax = xr, ymin = s.y[i] - e, ymax = s.y[i] + e;
        any = true;
      }
      xmin = std::min(xmin, s.x[i]);
      xmax = std::max(xmax, xr);
      ymin = std::min(ymin, s.y[i] - e);
      ymax = std::max(ymax, s.y[i] + e);
    }
  }
  if (plot.y_from_zero) ymin = std::min(0.0, ymin);
  if (plot.x_from_zero) xmin = std::min(0.0, xmin);
  if (!(xmax > xmin)) xmax = xmin + 1;
  if (!(ymax > ymin)) ymax = ymin + (ymin == 0 ? 1 : std::fabs(ymin) * 0.1);
  ymax += (ymax - ymin) * 0.05;
  // The left margin holds the vertical y label (8 rows of glyph from x = 12), a gap and the
  // widest y tick label: long ticks such as 0.0001234 used to run into the label.
  int widest_tick = 0;
  for (double t : nice_ticks(ymin, ymax))
    widest_tick = std::max(widest_tick, text_width(tick_label(t)));
  const int x0 = std::max(100, 12 + 8 * kTextScale + 12 + widest_tick + 10);
  auto px = [&](double x) {
    return x0 + static_cast<int>(std::lround((x - xmin) / (xmax - xmin) * (x1 - x0)));
  };
  auto py = [&](double y) {
    return y0 - static_cast<int>(std::lround((y - ymin) / (ymax - ymin) * (y0 - y1)));
  };
  // Grid lines and ticks.
  for (double t : nice_ticks(ymin, ymax)) {
    const int y = py(t);
    for (int x = x0; x <= x1; x += 4) img.set(x, y, kGrey);
    fill_rect(img, x0 - 6, y, x0, y, kBlack);
    const std::string label = tick_label(t);
    draw_text(img, x0 - 10 - text_width(label), y - 4 * kTextScale, label, kBlack);
  }
  for (double t : nice_ticks(xmin, xmax)) {
    const int x = px(t);
    for (int y = y1; y <= y0; y += 4) img.set(x, y, kGrey);
    fill_rect(img, x, y0, x, y0 + 6, kBlack);
    const std::string label = tick_label(t);
    draw_text(img, x - text_width(label) / 2, y0 + 12, label, kBlack);
  }
  // Data.
  for (const Series& s : all) {
    const std::size_t n = std::min(s.x.size(), s.y.size());
    if (s.style == PlotStyle::kBars) {
      for (std::size_t i = 0; i < n; ++i) {
        const int a = px(s.x[i]), b = px(s.x[i] + plot.bar_width) - 1;
        if (s.y[i] == 0) continue;
        fill_rect(img, a, py(s.y[i]), std::max(a, b), py(0) - 1, s.colour);
      }
      continue;
    }
    for (std::size_t i = 0; i < n && i < s.y_error.size(); ++i)
      draw_error_bar(img, px(s.x[i]), py(s.y[i] - s.y_error[i]), py(s.y[i] + s.y_error[i]),
                     s.colour);
    if (s.style == PlotStyle::kLine) {
      for (std::size_t i = 1; i < n; ++i)
        draw_line(img, px(s.x[i - 1]), py(s.y[i - 1]), px(s.x[i]), py(s.y[i]), s.colour);
    }
    if (s.style == PlotStyle::kPoints || n == 1)
      for (std::size_t i = 0; i < n; ++i) draw_point(img, px(s.x[i]), py(s.y[i]), s.colour);
  }
  // Legend, top left inside the axes.
  int ly = y1 + 10;
  for (const Series& s : all) {
    if (s.label.empty()) continue;
    const int lx = x0 + 14;
    if (s.style == PlotStyle::kPoints)
      draw_point(img, lx + 10, ly + 7, s.colour);
    else
      fill_rect(img, lx, ly + 6, lx + 20, ly + 8, s.colour);
    draw_text(img, lx + 30, ly, s.label, kBlack);
    ly += 22;
  }
  // Axes and titles.
  fill_rect(img, x0, y1, x0 + 1, y0, kBlack);
  fill_rect(img, x0, y0, x1, y0 + 1, kBlack);
  draw_text(img, (x0 + x1 - text_width(plot.title)) / 2, 15, plot.title, kBlack);
  draw_text(img, (x0 + x1 - text_width(plot.x_label)) / 2, plot.height - 28, plot.x_label, kBlack);
  draw_text(img, 12, (y0 + y1 + text_width(plot.y_label)) / 2, plot.y_label, kBlack,
            /*vertical=*/true);
  return img;
}

void write_plot_png(const Plot& plot, const std::filesystem::path& path,
                    const std::string& display_name) {
  write_png(render_plot(plot), path, display_name);
}

}  // namespace mesorock::plot
