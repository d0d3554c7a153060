#include "fourk/grid48.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <string>
#include <tuple>
#include <type_traits>
#include <unordered_map>
#include <utility>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "multitri/errors.hpp"

#include <glm/mat3x3.hpp>
#include <glm/matrix.hpp>

namespace varmesh {
namespace {

// The plane through three lattice points (x, y, z), as z = base + gx * x + gy * y.
struct PlaneXY {
  double gx = 0.0, gy = 0.0, base = 0.0;
  PlaneXY(double ax, double ay, double az, double bx, double by, double bz, double cx, double cy, double cz) {
    const double e1x = bx - ax, e1y = by - ay, e2x = cx - ax, e2y = cy - ay;
    const double det = e1x * e2y - e2x * e1y;
    gx = ((bz - az) * e2y - (cz - az) * e1y) / det;
    gy = ((cz - az) * e1x - (bz - az) * e2x) / det;
    base = az - gx * ax - gy * ay;
  }
};

// Largest tile (cells per side): the automatic choice and Grid48Options::tile_size stay within it.
constexpr std::size_t kMaxTileSize = std::size_t(1) << 15;

float round_up(double v) {
  float f = static_cast<float>(v);
  if (static_cast<double>(f) < v) f = std::nextafter(f, 3.0e38f);
  return f;
}

// The size rule of Grid48's constructor. Every distance the build squares in float (bounding spheres: a
// diamond's corners and children from its centre) is at most the diagonal of the lattice's box, padding
// included, and every node error at most the height span (the exact errors) or a few dozen times it (the
// fast bound): all finite when the diagonal squared is, with a margin for rounding (the limit of the
// command line's height field and mesh readers too). zlo and zhi are the lowest and highest samples.
void check_span(const HeightField& field, std::size_t lw, std::size_t lh, float zlo, float zhi) {
  const double dx = double(lw - 1) * double(field.spacing_x), dy = double(lh - 1) * double(field.spacing_y);
  const double dz = double(zhi) - double(zlo);
  constexpr double kLimit = 0.999 * double(std::numeric_limits<float>::max());
  auto too_big = [](double x, double y, double z) { return !(x * x + y * y + z * z <= kLimit); };
  if (!too_big(dx, dy, dz)) return;
  auto g = [](double v) {
    char text[32];
    std::snprintf(text, sizeof text, "%g", v);
    return std::string(text);
  };
  // The first sample holding a height, and its (row, column).
  auto index_of = [&](float z) {
    return static_cast<std::size_t>(std::find(field.z.begin(), field.z.end(), z) - field.z.begin());
  };
  auto at = [&](float z) {
    const std::size_t i = index_of(z);
    return g(double(z)) + " at (row " + std::to_string(i / field.width) + ", column " + std::to_string(i % field.width) + ")";
  };
  const std::string tail =
      ": more than about 1.8e19, too large to measure node errors and bounding spheres in float (their squared "
      "distances overflow)";
  if (too_big(0.0, 0.0, dz))
    throw InvalidInput("Grid48: the heights span " + g(dz) + ", from " + at(zlo) + " to " + at(zhi) + tail, index_of(zhi));
  if (too_big(dx, 0.0, 0.0))
    throw InvalidInput("Grid48: spacing_x " + g(field.spacing_x) + " times " + std::to_string(lw - 1) +
                       " lattice steps is " + g(dx) + " across" + tail);
  if (too_big(0.0, dy, 0.0))
    throw InvalidInput("Grid48: spacing_y " + g(field.spacing_y) + " times " + std::to_string(lh - 1) +
                       " lattice steps is " + g(dy) + " across" + tail);
  throw InvalidInput("Grid48: the lattice's box is " + g(std::sqrt(dx * dx + dy * dy + dz * dz)) + " across (" +
                     std::to_string(lw) + " x " + std::to_string(lh) + " lattice points, spacing_x " + g(field.spacing_x) +
                     ", spacing_y " + g(field.spacing_y) + (zhi > zlo ? ", heights from " + at(zlo) + " to " + at(zhi) : "") +
                     ")" + tail);
}

}  // namespace

Grid48::Grid48(const HeightField& field, const Grid48Options& options) {
  field.validate();
  width_ = field.width;
  height_ = field.height;
  if (width_ < 2 || height_ < 2) throw InvalidInput("Grid48: the grid must be at least 2 x 2 samples");
  if (!(options.max_padding >= 1.0)) throw InvalidInput("Grid48: max_padding must be >= 1");
  sx_ = field.spacing_x;
  sy_ = field.spacing_y;
  const std::size_t cw = width_ - 1, ch = height_ - 1;
  auto padded = [&](std::size_t s) {
    const std::size_t tx = (cw + s - 1) / s, ty = (ch + s - 1) / s;
    return std::pair{tx, ty};
  };
  std::size_t s = 1;
  if (options.tile_size != 0) {
    s = options.tile_size;
    if ((s & (s - 1)) != 0 || s < 2 || s > kMaxTileSize)
      throw InvalidInput("Grid48: tile_size " + std::to_string(s) + " is not a power of two in [2, 2^15]");
  } else {
    // The largest tile whose padding stays within max_padding (at least 2 cells).
    const double area = double(cw) * double(ch);
    s = 2;
    for (std::size_t t = 4; t <= kMaxTileSize && t / 2 < std::max(cw, ch); t *= 2) {
      const auto [tx, ty] = padded(t);
      if (double(tx * t) * double(ty * t) <= options.max_padding * area) s = t;
    }
  }
  tile_ = s;
  log2_tile_ = detail::grid48_ctz(s);
  std::tie(tx_, ty_) = padded(s);
  lw_ = tx_ * s + 1;
  lh_ = ty_ * s + 1;
  if (double(lw_) * double(lh_) > double(1u << 30)) throw InvalidInput("Grid48: grid too large (more than 2^30 lattice points)");
  check_span(field, lw_, lh_, field.z[0], field.z[0]);  // the spacings alone, before allocating
  row_of_ = detail::FastDivider(static_cast<std::uint32_t>(lw_));
  // Heights straight into the records (padding repeats the last row and column); errors come later.
  records_.resize(lw_ * lh_);
  float zlo = field.z[0], zhi = field.z[0];
  for (std::size_t y = 0; y < lh_; ++y) {
    const float* src = field.z.data() + std::min(y, height_ - 1) * width_;
    PointRecord* dst = records_.data() + y * lw_;
    if (y < height_) {
      for (std::size_t x = 0; x < width_; ++x) {
        zlo = std::min(zlo, src[x]);
        zhi = std::max(zhi, src[x]);
        dst[x] = {0.0f, src[x]};
      }
    } else {
      for (std::size_t x = 0; x < width_; ++x) dst[x] = {0.0f, src[x]};
    }
    for (std::size_t x = width_; x < lw_; ++x) dst[x] = {0.0f, src[width_ - 1]};
  }
  check_span(field, lw_, lh_, zlo, zhi);
  if (options.reference_scan) {
    z_.resize(lw_ * lh_);
    for (std::size_t p = 0; p < records_.size(); ++p) z_[p] = records_[p].z;
    compute_errors();
    compute_radii();
    for (std::size_t p = 0; p < records_.size(); ++p) records_[p].error = error_[p];
    z_ = {};
    error_ = {};
  } else {
    compute_bounds_fast(options.exact_errors);
  }
  build_histogram();
}

Grid48::Grid48(Grid48&& other) noexcept { *this = std::move(other); }

Grid48& Grid48::operator=(Grid48&& other) noexcept {
  if (this == &other) return *this;
  // Every member is taken and reset to its initial value, so `other` is an empty hierarchy.
  width_ = std::exchange(other.width_, 0);
  height_ = std::exchange(other.height_, 0);
  lw_ = std::exchange(other.lw_, 0);
  lh_ = std::exchange(other.lh_, 0);
  tile_ = std::exchange(other.tile_, 1);
  tx_ = std::exchange(other.tx_, 0);
  ty_ = std::exchange(other.ty_, 0);
  log2_tile_ = std::exchange(other.log2_tile_, 0);
  sx_ = std::exchange(other.sx_, 1.0f);
  sy_ = std::exchange(other.sy_, 1.0f);
  row_of_ = std::exchange(other.row_of_, detail::FastDivider{});
  z_ = std::exchange(other.z_, {});
  error_ = std::exchange(other.error_, {});
  records_ = std::exchange(other.records_, {});
  radius_ = std::exchange(other.radius_, {});
  hist_key0_ = std::exchange(other.hist_key0_, 0);
  refined_above_ = std::exchange(other.refined_above_, {});
  faces_above_ = std::exchange(other.faces_above_, {});
  return *this;
}

namespace {

// Key of a non-negative float: its bits >> 18 (monotone in the value; 32 keys per octave).
std::uint32_t error_key(float e) noexcept {
  std::uint32_t bits;
  std::memcpy(&bits, &e, 4);
  return bits >> 18;
}

}  // namespace

void Grid48::build_histogram() {
  float top = 0.0f;
  for (const PointRecord& r : records_) top = std::max(top, r.error);
  // Slot 0: nodes of error 0 (the padding, flat areas), which no threshold >= 0 refines; slot 1 + k: key
  // hist_key0_ + k, where keys more than 24 octaves below the largest error share slot 1 (still a bound).
  hist_key0_ = error_key(top * 0x1p-24f);
  const std::size_t slots = 2 + error_key(top) - hist_key0_;
  refined_above_.assign(slots + 1, 0);
  faces_above_.assign(slots + 1, 0);
  // Row by row: every point but the tile corners is a node; one removes 2 faces, or 1 on the lattice
  // border (the num_triangles() rule).
  const std::size_t mask = tile_ - 1;
  for (std::size_t y = 0; y < lh_; ++y) {
    const PointRecord* row = records_.data() + y * lw_;
    const bool tile_row = (y & mask) == 0, border_row = y == 0 || y + 1 == lh_;
    for (std::size_t x = 0; x < lw_; ++x) {
      if (tile_row && (x & mask) == 0) continue;
      const float e = row[x].error;
      const std::size_t k = e > 0.0f ? 1 + std::max(error_key(e), hist_key0_) - hist_key0_ : 0;
      ++refined_above_[k];
      faces_above_[k] += (border_row || x == 0 || x + 1 == lw_) ? 1u : 2u;
    }
  }
  for (std::size_t k = slots; k-- > 0;) {
    refined_above_[k] += refined_above_[k + 1];
    faces_above_[k] += faces_above_[k + 1];
  }
}

// Nodes with error > threshold >= 0 have a positive error and key >= key(threshold): the suffix sum from
// that slot bounds them.
std::size_t Grid48::histogram_slot(float threshold) const noexcept {
  if (!(threshold >= 0.0f)) return 0;  // also NaN: every node may refine
  const std::uint32_t k = std::max(error_key(threshold), hist_key0_) - hist_key0_;
  return std::min<std::size_t>(1 + std::size_t{k}, refined_above_.size() - 1);
}

std::size_t Grid48::max_refined_above(float threshold) const noexcept {
  return refined_above_[histogram_slot(threshold)];
}

std::size_t Grid48::max_faces_above(float threshold) const noexcept {
  return 2 * tx_ * ty_ + faces_above_[histogram_slot(threshold)];
}

namespace {

// The diamond at (x, y) of size d = 2^ld: hypotenuse ends (b, c) and the two apexes (either may lie
// outside the lattice).
struct Corners {
  std::ptrdiff_t bx, by, cx, cy, ax[2], ay[2];
};
Corners diamond_corners(std::ptrdiff_t x, std::ptrdiff_t y, std::ptrdiff_t d, int ld, bool square) {
  Corners k;
  if (square) {
    const std::ptrdiff_t qx = (((x - d) >> (ld + 1)) & 1) != 0 ? x - d : x + d;
    const std::ptrdiff_t qy = (((y - d) >> (ld + 1)) & 1) != 0 ? y - d : y + d;
    k = {qx, qy, 2 * x - qx, 2 * y - qy, {2 * x - qx, qx}, {qy, 2 * y - qy}};
  } else if (((y >> ld) & 1) == 0) {  // horizontal split edge
    k = {x - d, y, x + d, y, {x, x}, {y - d, y + d}};
  } else {  // vertical split edge
    k = {x, y - d, x, y + d, {x - d, x + d}, {y, y}};
  }
  return k;
}

// Calls fn(y, d, ld, square, x_begin, x_end) for every row of diamonds, finest level first (edge
// diamonds of size d, then squares of size d, for d = 1, 2, 4, ...): the row's diamonds are at
// x_begin, x_begin + 2d, ... < x_end. A diamond reads only finer levels (and, for squares, the edge
// diamonds of its own size), so the rows of one pass may run in any order.
template <class Fn>
void for_each_diamond_row(std::ptrdiff_t w, std::ptrdiff_t h, int log2_tile, Fn&& fn) {
  for (int ld = 0; ld < log2_tile; ++ld) {
    const std::ptrdiff_t d = std::ptrdiff_t(1) << ld;
    for (int pass = 0; pass < 2; ++pass) {
      const bool square = pass == 1;
      for (std::ptrdiff_t y = 0; y < h; y += d) {
        const bool yodd = ((y >> ld) & 1) != 0;
        if (square && !yodd) continue;
        fn(y, d, ld, square, (square || !yodd) ? d : 0, w);
      }
    }
  }
}

// Splits a row of diamonds (as for_each_diamond_row gives it) into the run whose corners are all grid
// samples, interior(x0, x1) for the diamonds at x0, x0 + 2d, ..., x1, and the others, border(x) each.
template <class Interior, class Border>
void split_row(std::ptrdiff_t y, std::ptrdiff_t d, std::ptrdiff_t x_begin, std::ptrdiff_t x_end, std::ptrdiff_t last_x,
               std::ptrdiff_t last_y, Interior&& interior, Border&& border) {
  std::ptrdiff_t x = x_begin;
  if (y >= d && y + d <= last_y) {
    if (x < d) {  // x = 0: its left corner is outside the lattice
      border(x);
      x += 2 * d;
    }
    if (x + d <= last_x) {  // x - d >= 0 here; the run ends at the last x + d <= last_x
      const std::ptrdiff_t x1 = x + ((last_x - d - x) / (2 * d)) * (2 * d);
      interior(x, x1);
      x = x1 + 2 * d;
    }
  }
  for (; x < x_end; x += 2 * d) border(x);
}

// Visits every diamond, finest level first: fn(x, y, d, square) (the order of for_each_diamond_row).
template <class Fn>
void for_each_diamond_finest_first(std::ptrdiff_t w, std::ptrdiff_t h, int log2_tile, Fn&& fn) {
  for_each_diamond_row(w, h, log2_tile, [&](std::ptrdiff_t y, std::ptrdiff_t d, int, bool square, std::ptrdiff_t x_begin, std::ptrdiff_t x_end) {
    for (std::ptrdiff_t x = x_begin; x < x_end; x += 2 * d) fn(x, y, d, square);
  });
}

}  // namespace

// Nested radii, finest first, and the node errors: exact ones from compute_exact_errors(), or the fast
// bound below, from signed residual ranges in the same pass as the radii.
//
// For a triangle T split at the midpoint m of its hypotenuse (b, c) into children c0, c1: over a child,
// plane_child - plane_T is linear, 0 at the child's two corners shared with T and
// delta = h(m) - (h(b) + h(c)) / 2 at m, so it lies between min(0, delta) and max(0, delta). Hence the
// residual h - plane_T over T lies in [min over children of (rmin_child + min(0, delta)),
// max over children of (rmax_child + max(0, delta))]: a true bound that costs O(1) per triangle. Finest
// triangles have all their samples at their corners: range [0, 0]; triangles with no grid sample (in the
// padding) have an empty range. Triangles are stored as (diamond, side): side 0 is the half whose apex is
// left of the centre (or below it, on a vertical line), side 1 the other.
void Grid48::compute_bounds_fast(bool exact) {
  const std::size_t n = lw_ * lh_;
  radius_.assign(n, 0.0f);
  if (exact) compute_exact_errors();  // then only the radii below
  // Per triangle (2 per lattice point): the range of h - plane over its grid samples, empty by default.
  HugeVector<float> ranges(exact ? 0 : 4 * n);
  float* const rmin = ranges.data();
  float* const rmax = exact ? nullptr : rmin + 2 * n;
  std::fill(rmin, rmin + (exact ? 0 : 2 * n), 3.0e38f);
  std::fill(rmax, rmax + (exact ? 0 : 2 * n), -3.0e38f);
  const std::ptrdiff_t w = static_cast<std::ptrdiff_t>(lw_), h = static_cast<std::ptrdiff_t>(lh_);
  const std::ptrdiff_t last_x = static_cast<std::ptrdiff_t>(width_) - 1, last_y = static_cast<std::ptrdiff_t>(height_) - 1;
  PointRecord* const rec = records_.data();  // heights in, errors out
  auto in_grid = [&](std::ptrdiff_t x, std::ptrdiff_t y) { return x <= last_x && y <= last_y; };
  // Range of the child triangle with apex (px, py) and hypotenuse (ax, ay)-(bx, by).
  auto child_range = [&](std::ptrdiff_t px, std::ptrdiff_t py, std::ptrdiff_t ax, std::ptrdiff_t ay, std::ptrdiff_t bx,
                         std::ptrdiff_t by, float& lo, float& hi) {
    const std::ptrdiff_t sx = ax + bx, sy = ay + by;
    if (((sx | sy) & 1) != 0) {  // finest: samples are the corners
      if (in_grid(px, py) || in_grid(ax, ay) || in_grid(bx, by)) {
        lo = 0.0f;
        hi = 0.0f;
      } else {
        lo = 3.0e38f;
        hi = -3.0e38f;
      }
      return;
    }
    const std::ptrdiff_t mx = sx / 2, my = sy / 2;
    const int side = (px < mx || (px == mx && py < my)) ? 0 : 1;
    const std::size_t t = 2 * static_cast<std::size_t>(my * w + mx) + static_cast<std::size_t>(side);
    lo = rmin[t];
    hi = rmax[t];
  };
  // Any diamond, near the padding or not.
  auto visit = [&](std::ptrdiff_t x, std::ptrdiff_t y, std::ptrdiff_t d, bool square) {
    const int ld = detail::grid48_ctz(static_cast<std::size_t>(d));
    const std::size_t p = static_cast<std::size_t>(y * w + x);
    const Corners cn = diamond_corners(x, y, d, ld, square);
    const std::ptrdiff_t bx = cn.bx, by = cn.by, cx = cn.cx, cy = cn.cy;
    const std::ptrdiff_t a0x = cn.ax[0], a0y = cn.ay[0], a1x = cn.ax[1], a1y = cn.ay[1];
    const double hb = rec[by * w + bx].z, hc = rec[cy * w + cx].z, hm = rec[p].z;
    const double delta = hm - 0.5 * (hb + hc);
    const float dlo = static_cast<float>(std::min(0.0, delta)), dhi = static_cast<float>(std::max(0.0, delta));
    float err = 0.0f;
    const glm::vec3 centre(float(x) * sx_, float(y) * sy_, rec[p].z);
    float r = 0.0f;
    for (int k = 0; k < 2; ++k) {
      const std::ptrdiff_t ax = k == 0 ? a0x : a1x, ay = k == 0 ? a0y : a1y;
      if (ax < 0 || ay < 0 || ax >= w || ay >= h) continue;
      const int side = (ax < x || (ax == x && ay < y)) ? 0 : 1;
      float lo = 3.0e38f, hi = -3.0e38f;
      if (!exact) {
        float lo0, hi0, lo1, hi1;
        child_range(x, y, ax, ay, bx, by, lo0, hi0);
        child_range(x, y, cx, cy, ax, ay, lo1, hi1);
        if (lo0 <= hi0) {
          lo = std::min(lo, lo0 + dlo);
          hi = std::max(hi, hi0 + dhi);
        }
        if (lo1 <= hi1) {
          lo = std::min(lo, lo1 + dlo);
          hi = std::max(hi, hi1 + dhi);
        }
        if (lo <= hi) {
          // Outward rounding keeps the float range a bound of the double computation.
          lo -= std::abs(lo) * 1e-6f + 1e-30f;
          hi += std::abs(hi) * 1e-6f + 1e-30f;
          err = std::max({err, hi, -lo});
        }
        rmin[2 * p + static_cast<std::size_t>(side)] = lo;
        rmax[2 * p + static_cast<std::size_t>(side)] = hi;
      }
      const glm::vec3 apex(float(ax) * sx_, float(ay) * sy_, rec[ay * w + ax].z);
      r = std::max(r, glm::length(apex - centre));
    }
    r = std::max({r, glm::length(glm::vec3(float(bx) * sx_, float(by) * sy_, float(hb)) - centre),
                  glm::length(glm::vec3(float(cx) * sx_, float(cy) * sy_, float(hc)) - centre)});
    for_each_child(static_cast<Index>(p), [&](Index ch) {
      err = std::max(err, rec[ch].error);
      r = std::max(r, glm::length(position(ch) - centre) + radius_[ch]);
    });
    if (!exact) rec[p].error = err;
    radius_[p] = r * (1.0f + 1e-6f);
  };

  // The diamonds whose corners are all grid samples (all but a thin band along the padding), a row at a
  // time. Along a row the corners, children and child triangles sit at the same
  // offsets from the diamond (squares alternate between two layouts), so those are worked out once per
  // row from the general corner rule; every value is computed as visit() would compute it.
  std::vector<float> colx(lw_), rowy(lh_);
  for (std::ptrdiff_t x = 0; x < w; ++x) colx[x] = float(x) * sx_;
  for (std::ptrdiff_t y = 0; y < h; ++y) rowy[y] = float(y) * sy_;
  float* const lo_of = rmin;
  float* const hi_of = rmax;
  float* const rad_of = radius_.data();
  struct Layout {
    std::ptrdiff_t px[4], py[4], pl[4];  // corners a0, a1, b, c: offsets in x, y and index
    std::ptrdiff_t t0[2], t1[2];          // per apex: its two children triangles, offsets from 2 p
    std::ptrdiff_t side[2];               // per apex: the side its triangle is stored at
    std::ptrdiff_t qx[4], qy[4], ql[4];   // children diamonds
  };
  auto layout = [&](std::ptrdiff_t x, std::ptrdiff_t y, std::ptrdiff_t d, int ld, bool square) {
    const Corners cn = diamond_corners(x, y, d, ld, square);
    Layout l;
    const std::ptrdiff_t kx[4] = {cn.ax[0], cn.ax[1], cn.bx, cn.cx}, ky[4] = {cn.ay[0], cn.ay[1], cn.by, cn.cy};
    for (int j = 0; j < 4; ++j) l.px[j] = kx[j] - x, l.py[j] = ky[j] - y, l.pl[j] = l.py[j] * w + l.px[j];
    auto tri = [&](std::ptrdiff_t ux, std::ptrdiff_t uy, std::ptrdiff_t vx, std::ptrdiff_t vy) {
      const std::ptrdiff_t mx = (ux + vx) >> 1, my = (uy + vy) >> 1;
      return 2 * ((my * w + mx) - (y * w + x)) + ((x < mx || (x == mx && y < my)) ? 0 : 1);
    };
    for (int k = 0; k < 2; ++k) {
      l.t0[k] = tri(cn.ax[k], cn.ay[k], cn.bx, cn.by);
      l.t1[k] = tri(cn.cx, cn.cy, cn.ax[k], cn.ay[k]);
      l.side[k] = (cn.ax[k] < x || (cn.ax[k] == x && cn.ay[k] < y)) ? 0 : 1;
    }
    const std::ptrdiff_t e = square ? d : d >> 1;
    const std::ptrdiff_t sqx[4] = {-e, e, 0, 0}, sqy[4] = {0, 0, -e, e}, edx[4] = {-e, e, -e, e}, edy[4] = {-e, -e, e, e};
    for (int i = 0; i < 4; ++i) {
      l.qx[i] = square ? sqx[i] : edx[i];
      l.qy[i] = square ? sqy[i] : edy[i];
      l.ql[i] = l.qy[i] * w + l.qx[i];
    }
    return l;
  };
  // Specialised on the kind of errors and on the finest level (children are finest triangles, range
  // [0, 0], and there are no child diamonds), so that the loop carries no flags.
  auto row_loop = [&](auto exact_c, auto finest_c, std::ptrdiff_t x0, std::ptrdiff_t x1, std::ptrdiff_t y, std::ptrdiff_t d,
                      int ld, bool square) {
    constexpr bool kExact = decltype(exact_c)::value;
    constexpr bool kFinest = decltype(finest_c)::value;
    const Layout lay[2] = {layout(x0, y, d, ld, square), layout(x0 + 2 * d, y, d, ld, square)};
    const float ry = rowy[y];
    int parity = 0;
    for (std::ptrdiff_t x = x0; x <= x1; x += 2 * d, parity ^= 1) {
      const Layout& l = lay[square ? parity : 0];
      const std::ptrdiff_t p = y * w + x;
      const float zp = rec[p].z, rx = colx[x];
      const double delta = double(zp) - 0.5 * (double(rec[p + l.pl[2]].z) + double(rec[p + l.pl[3]].z));
      // visit()'s min(0, delta) and max(0, delta) rounded to float, written so that they compile to minss
      // and maxss: the sign of delta is a coin toss, a branch on it mispredicts half the time.
      const float df = static_cast<float>(delta);
      const float dlo = df < 0.0f ? df : 0.0f, dhi = df > 0.0f ? df : 0.0f;
      float side_err[2] = {0.0f, 0.0f};
      for (int k = 0; k < 2 && !kExact; ++k) {
        float lo0 = 0.0f, hi0 = 0.0f, lo1 = 0.0f, hi1 = 0.0f;
        if constexpr (!kFinest) {
          lo0 = lo_of[2 * p + l.t0[k]], hi0 = hi_of[2 * p + l.t0[k]];
          lo1 = lo_of[2 * p + l.t1[k]], hi1 = hi_of[2 * p + l.t1[k]];
        }
        // Both children hold grid samples (their corners), so neither range is empty.
        float lo = std::min(lo0 + dlo, lo1 + dlo), hi = std::max(hi0 + dhi, hi1 + dhi);
        lo -= std::abs(lo) * 1e-6f + 1e-30f;
        hi += std::abs(hi) * 1e-6f + 1e-30f;
        side_err[k] = std::max(hi, -lo);
        lo_of[2 * p + l.side[k]] = lo;
        hi_of[2 * p + l.side[k]] = hi;
      }
      // Maxima are exact, so trees of independent terms give visit()'s values; sqrt is monotone, so the
      // root of the largest squared corner distance is the largest corner distance.
      auto sq = [&](std::ptrdiff_t ox, std::ptrdiff_t oy, std::ptrdiff_t ol) {
        const glm::vec3 v(colx[x + ox] - rx, rowy[y + oy] - ry, rec[p + ol].z - zp);
        return glm::dot(v, v);
      };
      float r = std::sqrt(std::max(std::max(sq(l.px[0], l.py[0], l.pl[0]), sq(l.px[1], l.py[1], l.pl[1])),
                                   std::max(sq(l.px[2], l.py[2], l.pl[2]), sq(l.px[3], l.py[3], l.pl[3]))));
      float err = std::max(side_err[0], side_err[1]);
      if constexpr (!kFinest) {
        float ce[4], cr[4];
        for (int i = 0; i < 4; ++i) {
          ce[i] = rec[p + l.ql[i]].error;
          cr[i] = sq(l.qx[i], l.qy[i], l.ql[i]);
        }
#if defined(__SSE2__)
        // The four roots in one instruction (sqrtps rounds each lane as sqrtss would).
        const __m128 rr = _mm_add_ps(_mm_sqrt_ps(_mm_loadu_ps(cr)), _mm_setr_ps(rad_of[p + l.ql[0]], rad_of[p + l.ql[1]],
                                                                                  rad_of[p + l.ql[2]], rad_of[p + l.ql[3]]));
        _mm_storeu_ps(cr, rr);
#else
        for (int i = 0; i < 4; ++i) cr[i] = std::sqrt(cr[i]) + rad_of[p + l.ql[i]];
#endif
        err = std::max(err, std::max(std::max(ce[0], ce[1]), std::max(ce[2], ce[3])));
        r = std::max(r, std::max(std::max(cr[0], cr[1]), std::max(cr[2], cr[3])));
      }
      if constexpr (!kExact) rec[p].error = err;
      rad_of[p] = r * (1.0f + 1e-6f);
    }
  };
  auto row = [&](std::ptrdiff_t x0, std::ptrdiff_t x1, std::ptrdiff_t y, std::ptrdiff_t d, int ld, bool square) {
    using T = std::true_type;
    using F = std::false_type;
    const bool finest = !square && ld == 0;
    if (exact) {
      if (finest) row_loop(T{}, T{}, x0, x1, y, d, ld, square);
      else row_loop(T{}, F{}, x0, x1, y, d, ld, square);
    } else {
      if (finest) row_loop(F{}, T{}, x0, x1, y, d, ld, square);
      else row_loop(F{}, F{}, x0, x1, y, d, ld, square);
    }
  };
  for_each_diamond_row(w, h, log2_tile_, [&](std::ptrdiff_t y, std::ptrdiff_t d, int ld, bool square, std::ptrdiff_t x_begin, std::ptrdiff_t x_end) {
    split_row(
        y, d, x_begin, x_end, last_x, last_y, [&](std::ptrdiff_t x0, std::ptrdiff_t x1) { row(x0, x1, y, d, ld, square); },
        [&](std::ptrdiff_t x) { visit(x, y, d, square); });
  });
}

std::size_t Grid48::num_nodes() const noexcept { return lw_ * lh_ == 0 ? 0 : lw_ * lh_ - (tx_ + 1) * (ty_ + 1); }

std::size_t Grid48::memory_bytes() const noexcept {
  return records_.size() * sizeof(PointRecord) + radius_.size() * sizeof(float) +
         (refined_above_.size() + faces_above_.size()) * sizeof(std::uint32_t);
}

namespace {


// Largest |row[x] - (b + g x)| for x in [x0, x1].
inline double span_error(const float* row, std::ptrdiff_t x0, std::ptrdiff_t x1, double b, double g) {
  double worst = 0.0;
  std::ptrdiff_t x = x0;
#if defined(__SSE2__)
  // Four samples a step in two pairs of double lanes, each lane computing what the loop below computes.
  if (x1 - x0 >= 7) {
    const __m128d vb = _mm_set1_pd(b), vg = _mm_set1_pd(g), sign = _mm_set1_pd(-0.0), four = _mm_set1_pd(4.0);
    __m128d xa = _mm_setr_pd(double(x0), double(x0 + 1)), xb = _mm_setr_pd(double(x0 + 2), double(x0 + 3));
    __m128d wa = _mm_setzero_pd(), wb = _mm_setzero_pd();
    for (; x + 3 <= x1; x += 4) {
      const __m128 h = _mm_loadu_ps(row + x);
      const __m128d ha = _mm_cvtps_pd(h), hb = _mm_cvtps_pd(_mm_movehl_ps(h, h));
      wa = _mm_max_pd(wa, _mm_andnot_pd(sign, _mm_sub_pd(ha, _mm_add_pd(vb, _mm_mul_pd(vg, xa)))));
      wb = _mm_max_pd(wb, _mm_andnot_pd(sign, _mm_sub_pd(hb, _mm_add_pd(vb, _mm_mul_pd(vg, xb)))));
      xa = _mm_add_pd(xa, four);
      xb = _mm_add_pd(xb, four);
    }
    const __m128d m = _mm_max_pd(wa, wb);
    worst = std::max(_mm_cvtsd_f64(m), _mm_cvtsd_f64(_mm_unpackhi_pd(m, m)));
  }
#endif
  for (; x <= x1; ++x) {
    const double d = double(row[x]) - (b + g * double(x));
    worst = std::max(worst, std::abs(d));
  }
  return worst;
}

}  // namespace

// Exact node errors. A diamond's region is scanned row by row; each row is split where it crosses the
// diamond's split edge, and each part is compared with the plane of the triangle it lies in (samples on
// the split edge lie on both planes' common line, so either plane gives their residual). Each level's
// diamonds tile the lattice once, so a level costs one pass over the samples.
double Grid48::scan_own_error(std::ptrdiff_t x, std::ptrdiff_t y, std::ptrdiff_t d, bool square) const {
  const std::ptrdiff_t w = static_cast<std::ptrdiff_t>(lw_), h = static_cast<std::ptrdiff_t>(lh_);
  const std::ptrdiff_t last_x = static_cast<std::ptrdiff_t>(width_) - 1, last_y = static_cast<std::ptrdiff_t>(height_) - 1;
  if (x - d > last_x || y - d > last_y) return 0.0;  // only samples inside the grid count (padding repeats the border)
  auto zat = [&](std::ptrdiff_t px, std::ptrdiff_t py) { return double(z_[static_cast<std::size_t>(py * w + px)]); };
  double e = 0.0;
  if (square) {
    // Diagonal from (cx, cy) to the opposite corner (ox, oy) (the hypotenuse of diamond_corners); the
    // off-diagonal corners are the apexes of the two halves, one on the left column (x - d), one on the
    // right (x + d).
    const Corners cn = diamond_corners(x, y, d, detail::grid48_ctz(static_cast<std::size_t>(d)), true);
    const std::ptrdiff_t cx = cn.bx, cy = cn.by, ox = cn.cx, oy = cn.cy;
    // Off corners: (ox, cy) and (cx, oy).
    const bool first_left = ox == x - d;
    const std::ptrdiff_t lx = first_left ? ox : cx, ly = first_left ? cy : oy;
    const std::ptrdiff_t rx = first_left ? cx : ox, ry = first_left ? oy : cy;
    const PlaneXY left(double(lx), double(ly), zat(lx, ly), double(cx), double(cy), zat(cx, cy), double(ox), double(oy), zat(ox, oy));
    const PlaneXY right(double(rx), double(ry), zat(rx, ry), double(cx), double(cy), zat(cx, cy), double(ox), double(oy), zat(ox, oy));
    const std::ptrdiff_t slope = (ox - cx) * (oy - cy) > 0 ? 1 : -1;  // diagonal x - x_c = slope (y - y_c)
    const std::ptrdiff_t y1 = std::min(y + d, last_y);
    const std::ptrdiff_t xr = std::min(x + d, last_x);
    for (std::ptrdiff_t yy = y - d; yy <= y1; ++yy) {
      const std::ptrdiff_t split = x + slope * (yy - y);
      const float* row = z_.data() + yy * w;
      e = std::max(e, span_error(row, x - d, std::min(split, last_x), left.base + left.gy * double(yy), left.gx));
      if (split <= last_x) e = std::max(e, span_error(row, split, xr, right.base + right.gy * double(yy), right.gx));
    }
  } else {
    const int lx = detail::grid48_ctz(static_cast<std::size_t>(x)), ly = detail::grid48_ctz(static_cast<std::size_t>(y));
    const bool horizontal = lx < ly;  // split edge along x, apexes below and above
    // Triangle apexes: (below|left) and (above|right); missing outside the lattice.
    const std::ptrdiff_t ax0 = horizontal ? x : x - d, ay0 = horizontal ? y - d : y;
    const std::ptrdiff_t ax1 = horizontal ? x : x + d, ay1 = horizontal ? y + d : y;
    const std::ptrdiff_t ex0 = horizontal ? x - d : x, ey0 = horizontal ? y : y - d;
    const std::ptrdiff_t ex1 = horizontal ? x + d : x, ey1 = horizontal ? y : y + d;
    const bool has0 = ax0 >= 0 && ay0 >= 0, has1 = ax1 < w && ay1 < h;
    PlaneXY p0(0, 0, 0, 1, 0, 0, 0, 1, 0), p1(0, 0, 0, 1, 0, 0, 0, 1, 0);
    if (has0) p0 = PlaneXY(double(ax0), double(ay0), zat(ax0, ay0), double(ex0), double(ey0), zat(ex0, ey0), double(ex1), double(ey1), zat(ex1, ey1));
    if (has1) p1 = PlaneXY(double(ax1), double(ay1), zat(ax1, ay1), double(ex0), double(ey0), zat(ex0, ey0), double(ex1), double(ey1), zat(ex1, ey1));
    const std::ptrdiff_t y0 = std::max<std::ptrdiff_t>(y - d, 0), y1 = std::min(y + d, last_y);
    for (std::ptrdiff_t yy = y0; yy <= y1; ++yy) {
      const std::ptrdiff_t half = d - std::abs(yy - y);
      const std::ptrdiff_t xa = std::max<std::ptrdiff_t>(x - half, 0), xb = std::min(x + half, last_x);
      if (xa > xb) continue;
      const float* row = z_.data() + yy * w;
      if (horizontal) {
        const PlaneXY& pl = yy < y ? p0 : p1;
        if ((yy < y && !has0) || (yy > y && !has1)) continue;
        const PlaneXY& use = yy == y ? (has0 ? p0 : p1) : pl;
        e = std::max(e, span_error(row, xa, xb, use.base + use.gy * double(yy), use.gx));
      } else {
        if (has0 && xa <= std::min(x, xb)) e = std::max(e, span_error(row, xa, std::min(x, xb), p0.base + p0.gy * double(yy), p0.gx));
        if (has1 && x <= xb) e = std::max(e, span_error(row, std::max(x, xa), xb, p1.base + p1.gy * double(yy), p1.gx));
      }
    }
  }
  return e;
}

// The reference for compute_exact_errors(): every diamond scanned by scan_own_error(), into error_.
void Grid48::compute_errors() {
  error_.assign(lw_ * lh_, 0.0f);
  const std::ptrdiff_t w = static_cast<std::ptrdiff_t>(lw_), h = static_cast<std::ptrdiff_t>(lh_);
  // Finest level first so that children are saturated before their parents.
  for_each_diamond_finest_first(w, h, log2_tile_, [&](std::ptrdiff_t x, std::ptrdiff_t y, std::ptrdiff_t d, bool square) {
      const int pass = square ? 1 : 0;
      const Index p = static_cast<Index>(y * w + x);
      const double e = scan_own_error(x, y, d, pass == 1);
      float sat = round_up(e);
      for_each_child(p, [&](Index c) { sat = std::max(sat, error_[c]); });
      error_[p] = sat;
    });
}

// Exact node errors, finest first, into records_. Diamonds of size d <= 4 away from the padding (most of
// the diamonds, and the ones whose few samples made scan_own_error() costly per sample) use per-row lists:
// for each sample of each triangle its offset and its barycentric weights in the triangle's corners. On
// the lattice those weights are dyadic (twice a triangle's area is a power of two), so the plane at a
// sample is a weighted sum of three heights, with nothing to set up per diamond. Larger diamonds, and
// those near the padding, are scanned row by row as compute_errors() does.
void Grid48::compute_exact_errors() {
  const std::ptrdiff_t w = static_cast<std::ptrdiff_t>(lw_), h = static_cast<std::ptrdiff_t>(lh_);
  const std::ptrdiff_t last_x = static_cast<std::ptrdiff_t>(width_) - 1, last_y = static_cast<std::ptrdiff_t>(height_) - 1;
  z_.resize(lw_ * lh_);
  for (std::size_t p = 0; p < records_.size(); ++p) z_[p] = records_[p].z;
  PointRecord* const rec = records_.data();
  struct Sample {
    std::ptrdiff_t off;
    double wa, wb, wc;
  };
  struct TriList {
    std::ptrdiff_t a, b, c;  // corner offsets
    std::vector<Sample> samples;
    std::ptrdiff_t child[4];  // the diamond's children (in the first list only), 0 for none
  };
  // The samples of the diamond at (x, y) other than its corners, per triangle (apex a, hypotenuse b-c;
  // samples on the hypotenuse are in both, with the same plane value).
  auto make_lists = [&](std::ptrdiff_t x, std::ptrdiff_t y, std::ptrdiff_t d, int ld, bool square, TriList (&out)[2]) {
    const Corners cn = diamond_corners(x, y, d, ld, square);
    // Children as in for_each_child: a square's side midpoints, the squares of size d / 2 around an edge
    // diamond (none at the finest level: offset 0 reads the diamond itself, whose error is not yet set).
    const std::ptrdiff_t e = square ? d : d >> 1;
    for (int i = 0; i < 4; ++i) {
      const std::ptrdiff_t cx = square ? (i < 2 ? (i == 0 ? -e : e) : 0) : (i % 2 == 0 ? -e : e);
      const std::ptrdiff_t cy = square ? (i < 2 ? 0 : (i == 2 ? -e : e)) : (i < 2 ? -e : e);
      out[0].child[i] = cy * w + cx;
    }
    for (int k = 0; k < 2; ++k) {
      const std::ptrdiff_t ax = cn.ax[k], ay = cn.ay[k];
      TriList& t = out[k];
      t.a = (ay - y) * w + (ax - x);
      t.b = (cn.by - y) * w + (cn.bx - x);
      t.c = (cn.cy - y) * w + (cn.cx - x);
      t.samples.clear();
      auto cross = [](std::ptrdiff_t ux, std::ptrdiff_t uy, std::ptrdiff_t vx, std::ptrdiff_t vy) { return ux * vy - uy * vx; };
      const std::ptrdiff_t area2 = cross(cn.bx - ax, cn.by - ay, cn.cx - ax, cn.cy - ay);
      for (std::ptrdiff_t sy = std::min({ay, cn.by, cn.cy}); sy <= std::max({ay, cn.by, cn.cy}); ++sy)
        for (std::ptrdiff_t sx = std::min({ax, cn.bx, cn.cx}); sx <= std::max({ax, cn.bx, cn.cx}); ++sx) {
          // Barycentric coordinates times area2: of b, of c, and the rest of a.
          const std::ptrdiff_t nb = cross(sx - ax, sy - ay, cn.cx - ax, cn.cy - ay);
          const std::ptrdiff_t nc = cross(cn.bx - ax, cn.by - ay, sx - ax, sy - ay);
          const std::ptrdiff_t na = area2 - nb - nc;
          const bool inside = area2 > 0 ? (na >= 0 && nb >= 0 && nc >= 0) : (na <= 0 && nb <= 0 && nc <= 0);
          const bool corner = na == area2 || nb == area2 || nc == area2;
          // Samples on the hypotenuse (na = 0) have the same plane value in both triangles: listed once.
          // Samples on a leg (nb = 0 or nc = 0) are skipped: a leg is the hypotenuse of a child triangle
          // whose plane agrees with this one along it, so the child's error, saturated below, covers them.
          if (!inside || corner || (k == 1 && na == 0) || nb == 0 || nc == 0) continue;
          t.samples.push_back({(sy - y) * w + (sx - x), double(na) / double(area2), double(nb) / double(area2),
                               double(nc) / double(area2)});
        }
    }
  };
  auto saturate = [&](std::size_t p, double e) {
    float sat = round_up(e);
    for_each_child(static_cast<Index>(p), [&](Index c) { sat = std::max(sat, rec[c].error); });
    rec[p].error = sat;
  };
  constexpr int kListLevels = 3;  // d = 1, 2, 4
  TriList lists[2][2];
  auto scan = [&](std::ptrdiff_t x, std::ptrdiff_t y, std::ptrdiff_t d, bool square) {
    saturate(static_cast<std::size_t>(y * w + x), scan_own_error(x, y, d, square));
  };
  auto listed = [&](std::ptrdiff_t x0, std::ptrdiff_t x1, std::ptrdiff_t y, std::ptrdiff_t d, int ld, bool square) {
    // Squares alternate between two layouts along a row; edge diamonds keep one.
    make_lists(x0, y, d, ld, square, lists[0]);
    make_lists(x0 + 2 * d, y, d, ld, square, lists[1]);
    int parity = 0;
    for (std::ptrdiff_t x = x0; x <= x1; x += 2 * d, parity ^= 1) {
      const std::size_t p = static_cast<std::size_t>(y * w + x);
      double e = 0.0;
      const TriList(&l)[2] = lists[square ? parity : 0];
      for (const TriList& t : l) {
        const double za = rec[p + t.a].z, zb = rec[p + t.b].z, zc = rec[p + t.c].z;
        for (const Sample& q : t.samples)
          e = std::max(e, std::abs(double(rec[p + q.off].z) - (q.wa * za + q.wb * zb + q.wc * zc)));
      }
      // Saturation as in saturate(); an error of 0 at offset 0 (finest edge diamonds) changes nothing.
      const std::ptrdiff_t* o = l[0].child;
      const float ce = std::max(std::max(rec[p + o[0]].error, rec[p + o[1]].error),
                                std::max(rec[p + o[2]].error, rec[p + o[3]].error));
      rec[p].error = std::max(round_up(e), ce);
    }
  };
  for_each_diamond_row(w, h, log2_tile_, [&](std::ptrdiff_t y, std::ptrdiff_t d, int ld, bool square, std::ptrdiff_t x_begin, std::ptrdiff_t x_end) {
    if (ld >= kListLevels) {
      for (std::ptrdiff_t x = x_begin; x < x_end; x += 2 * d) scan(x, y, d, square);
      return;
    }
    split_row(
        y, d, x_begin, x_end, last_x, last_y, [&](std::ptrdiff_t x0, std::ptrdiff_t x1) { listed(x0, x1, y, d, ld, square); },
        [&](std::ptrdiff_t x) { scan(x, y, d, square); });
  });
  z_ = {};
}

void Grid48::compute_radii() {
  radius_.assign(lw_ * lh_, 0.0f);
  const std::ptrdiff_t w = static_cast<std::ptrdiff_t>(lw_), h = static_cast<std::ptrdiff_t>(lh_);
  for_each_diamond_finest_first(w, h, log2_tile_, [&](std::ptrdiff_t x, std::ptrdiff_t y, std::ptrdiff_t d, bool square) {
      const int pass = square ? 1 : 0;
      const Index p = static_cast<Index>(y * w + x);
      const glm::vec3 c = position(p);
      float r = 0.0f;
      // Corners: the four axis neighbours at distance d (edge diamonds) or the four diagonal ones (squares).
      static constexpr int kAxis[4][2] = {{-1, 0}, {1, 0}, {0, -1}, {0, 1}};
      static constexpr int kDiag[4][2] = {{-1, -1}, {1, -1}, {-1, 1}, {1, 1}};
      for (int k = 0; k < 4; ++k) {
        const auto& o = pass == 1 ? kDiag[k] : kAxis[k];
        const std::ptrdiff_t qx = x + o[0] * d, qy = y + o[1] * d;
        if (qx < 0 || qy < 0 || qx >= w || qy >= h) continue;
        r = std::max(r, glm::length(position(static_cast<Index>(qy * w + qx)) - c));
      }
      for_each_child(p, [&](Index ch) { r = std::max(r, glm::length(position(ch) - c) + radius_[ch]); });
      radius_[p] = r * (1.0f + 1e-6f);
    });
}

Mt Grid48::to_mt() const {
  MtBuilder b;
  for (Index p = 0; p < lw_ * lh_; ++p) b.add_vertex(position(p));
  // Enumerate every triangle of the bintree; remember each diamond's triangles and their children.
  std::unordered_map<Index, std::vector<FaceId>> removed, created;
  std::vector<FaceId> base;
  std::vector<std::array<Index, 4>> work;  // apex, h0, h1, face
  Grid48Front roots(*this);
  roots.for_each_triangle([&](Index a, Index h0, Index h1) {
    const FaceId f = b.add_face(a, h0, h1);
    base.push_back(f);
    work.push_back({a, h0, h1, f});
  });
  while (!work.empty()) {
    const auto [a, h0, h1, f] = work.back();
    work.pop_back();
    const std::size_t x0 = h0 % lw_, y0 = h0 / lw_, x1 = h1 % lw_, y1 = h1 / lw_;
    if (((x0 + x1) | (y0 + y1)) & 1u) continue;
    const Index m = static_cast<Index>(((y0 + y1) / 2) * lw_ + (x0 + x1) / 2);
    removed[m].push_back(f);
    const FaceId c0 = b.add_face(m, a, h0), c1 = b.add_face(m, h1, a);
    created[m].push_back(c0);
    created[m].push_back(c1);
    work.push_back({m, a, h0, c0});
    work.push_back({m, h1, a, c1});
  }
  b.set_base(base);
  std::vector<Index> nodes;
  for (const auto& [m, faces] : removed) nodes.push_back(m);
  std::sort(nodes.begin(), nodes.end());
  for (Index m : nodes) b.add_node(NodeKind::kSplit, removed[m], created[m], error(m));
  return std::move(b).build();
}

double Grid48::max_vertical_error(const TriMesh& mesh) const {
  if (mesh.indices.size() % 3 != 0) throw InvalidInput("Grid48::max_vertical_error: index count is not a multiple of 3");
  for (std::size_t i = 0; i < mesh.indices.size(); ++i)
    if (mesh.indices[i] >= mesh.positions.size())
      throw InvalidInput("Grid48::max_vertical_error: face " + std::to_string(i / 3) + " refers to vertex " +
                             std::to_string(mesh.indices[i]) + " of " + std::to_string(mesh.positions.size()),
                         i / 3);
  for (std::size_t v = 0; v < mesh.positions.size(); ++v) {
    const glm::vec3& p = mesh.positions[v];
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
      throw InvalidInput("Grid48::max_vertical_error: vertex " + std::to_string(v) + " has a non-finite position", v);
  }
  std::vector<std::uint8_t> covered(width_ * height_, 0);
  double worst = 0.0;
  for (std::size_t f = 0; f < mesh.num_faces(); ++f) {
    glm::dvec3 v[3];
    // Lattice coordinates: a float position i * spacing divided by the spacing lands within a few float
    // ulps of i (an ulp inside the grid at its border, which left border samples "uncovered" and the
    // measure infinite for spacings other than 1); within 1e-6 relative, it is taken as i.
    auto lattice = [](double t) {
      const double r = std::round(t);
      return std::abs(t - r) <= 1e-6 * std::max(1.0, std::abs(r)) ? r : t;
    };
    for (int k = 0; k < 3; ++k) {
      const glm::vec3 p = mesh.positions[mesh.corner(f, k)];
      v[k] = {lattice(double(p.x) / sx_), lattice(double(p.y) / sy_), double(p.z)};
    }
    const double det = (v[1].x - v[0].x) * (v[2].y - v[0].y) - (v[2].x - v[0].x) * (v[1].y - v[0].y);
    if (std::abs(det) < 1e-12) continue;
    const double xmin = std::min({v[0].x, v[1].x, v[2].x}), xmax = std::max({v[0].x, v[1].x, v[2].x});
    const double ymin = std::min({v[0].y, v[1].y, v[2].y}), ymax = std::max({v[0].y, v[1].y, v[2].y});
    const auto x0 = static_cast<std::ptrdiff_t>(std::max(0.0, std::ceil(xmin - 1e-9)));
    const auto x1 = static_cast<std::ptrdiff_t>(std::min(double(width_ - 1), std::floor(xmax + 1e-9)));
    const auto y0 = static_cast<std::ptrdiff_t>(std::max(0.0, std::ceil(ymin - 1e-9)));
    const auto y1 = static_cast<std::ptrdiff_t>(std::min(double(height_ - 1), std::floor(ymax + 1e-9)));
    for (std::ptrdiff_t y = y0; y <= y1; ++y)
      for (std::ptrdiff_t x = x0; x <= x1; ++x) {
        const double px = double(x), py = double(y);
        const double l1 = ((px - v[0].x) * (v[2].y - v[0].y) - (v[2].x - v[0].x) * (py - v[0].y)) / det;
        const double l2 = ((v[1].x - v[0].x) * (py - v[0].y) - (px - v[0].x) * (v[1].y - v[0].y)) / det;
        const double l0 = 1.0 - l1 - l2;
        if (l0 < -1e-9 || l1 < -1e-9 || l2 < -1e-9) continue;
        const double zi = l0 * v[0].z + l1 * v[1].z + l2 * v[2].z;
        const std::size_t s = static_cast<std::size_t>(y) * width_ + static_cast<std::size_t>(x);
        covered[s] = 1;
        worst = std::max(worst, std::abs(zi - double(height_at(static_cast<Index>(static_cast<std::size_t>(y) * lw_ + static_cast<std::size_t>(x))))));
      }
  }
  for (std::uint8_t c : covered)
    if (!c) return HUGE_VAL;  // a hole: some sample is not under any triangle
  return worst;
}

namespace {

// A vertex of a clipped polygon, in lattice coordinates, with its lattice id when it is a lattice point.
struct CV {
  double x, y, z;
  Index lattice;
};

CV intersect(const CV& a, const CV& b, bool on_x, double line) {
  // Computed from the endpoints in a canonical order so both triangles sharing the edge get the same bits.
  const bool swap = (a.x > b.x) || (a.x == b.x && a.y > b.y);
  const CV& p = swap ? b : a;
  const CV& q = swap ? a : b;
  const double t = on_x ? (line - p.x) / (q.x - p.x) : (line - p.y) / (q.y - p.y);
  CV r{p.x + t * (q.x - p.x), p.y + t * (q.y - p.y), p.z + t * (q.z - p.z), kInvalid};
  if (on_x) r.x = line; else r.y = line;
  return r;
}

void clip(std::vector<CV>& poly, std::vector<CV>& tmp, bool on_x, double line) {
  tmp.clear();
  const std::size_t n = poly.size();
  for (std::size_t i = 0; i < n; ++i) {
    const CV& a = poly[i];
    const CV& b = poly[(i + 1) % n];
    const double va = on_x ? a.x : a.y, vb = on_x ? b.x : b.y;
    const bool ia = va <= line, ib = vb <= line;
    if (ia) tmp.push_back(a);
    if (ia != ib && va != line && vb != line) tmp.push_back(intersect(a, b, on_x, line));
  }
  poly.swap(tmp);
}

// Clips triangles (lattice points, counter-clockwise) to the grid rectangle [0, xmax] x [0, ymax] (lattice
// units) and appends the pieces to a mesh as fans. lattice_vertex(p) gives the vertex of a lattice point
// inside the rectangle; points created on the clipping lines are shared through a hash map.
class GridClipper {
 public:
  GridClipper(const Grid48& g, TriMesh& out, std::vector<Index>& ids)
      : g_(g), out_(out), ids_(ids), xmax_(double(g.grid_width() - 1)), ymax_(double(g.grid_height() - 1)) {}

  template <class LatticeVertex>
  void add(Index a, Index b, Index c, LatticeVertex&& lattice_vertex) {
    const CV va = cv(a), vb = cv(b), vc = cv(c);
    if (std::max({va.x, vb.x, vc.x}) <= xmax_ && std::max({va.y, vb.y, vc.y}) <= ymax_) {
      out_.indices.push_back(lattice_vertex(a));
      out_.indices.push_back(lattice_vertex(b));
      out_.indices.push_back(lattice_vertex(c));
      return;
    }
    if (std::min({va.x, vb.x, vc.x}) >= xmax_ || std::min({va.y, vb.y, vc.y}) >= ymax_) return;
    poly_.assign({va, vb, vc});
    clip(poly_, tmp_, true, xmax_);
    if (poly_.size() >= 3) clip(poly_, tmp_, false, ymax_);
    if (poly_.size() < 3) return;
    Index vid[8];
    for (std::size_t k = 0; k < poly_.size(); ++k)
      vid[k] = poly_[k].lattice != kInvalid ? lattice_vertex(poly_[k].lattice) : clip_vertex(poly_[k]);
    // Fan from a vertex that makes no zero-area triangle (clipped polygons can have three collinear
    // vertices on a clipping line; fanning from the middle one keeps every vertex, so no T-junction).
    const std::size_t n = poly_.size();
    auto area = [&](std::size_t i, std::size_t j, std::size_t k) {
      return (poly_[j].x - poly_[i].x) * (poly_[k].y - poly_[i].y) - (poly_[k].x - poly_[i].x) * (poly_[j].y - poly_[i].y);
    };
    std::size_t apex = 0;
    for (std::size_t s0 = 0; s0 < n; ++s0) {
      bool ok = true;
      for (std::size_t k = 1; k + 1 < n && ok; ++k) ok = area(s0, (s0 + k) % n, (s0 + k + 1) % n) > 0.0;
      if (ok) {
        apex = s0;
        break;
      }
    }
    for (std::size_t k = 1; k + 1 < n; ++k) {
      const std::size_t j = (apex + k) % n, l = (apex + k + 1) % n;
      if (area(apex, j, l) <= 0.0) continue;
      out_.indices.push_back(vid[apex]);
      out_.indices.push_back(vid[j]);
      out_.indices.push_back(vid[l]);
    }
  }

 private:
  CV cv(Index p) const {
    return CV{double(g_.px(p)), double(g_.py(p)), double(g_.height_at(p)), p};
  }
  Index clip_vertex(const CV& v) {
    float fx = static_cast<float>(v.x), fy = static_cast<float>(v.y);
    std::uint32_t bx, by;
    std::memcpy(&bx, &fx, 4);
    std::memcpy(&by, &fy, 4);
    auto [it, inserted] = clip_vertices_.try_emplace((std::uint64_t(bx) << 32) | by, static_cast<Index>(out_.positions.size()));
    if (inserted) {
      out_.positions.push_back({fx * g_.spacing_x(), fy * g_.spacing_y(), static_cast<float>(v.z)});
      ids_.push_back(kInvalid);
    }
    return it->second;
  }

  const Grid48& g_;
  TriMesh& out_;
  std::vector<Index>& ids_;
  double xmax_, ymax_;
  std::unordered_map<std::uint64_t, Index> clip_vertices_;
  std::vector<CV> poly_, tmp_;
};

}  // namespace

Grid48Front::Grid48Front(const Grid48& grid) : grid_(&grid) {
  if (grid.num_points() == 0) throw InvalidInput("Grid48Front: the grid is empty (a moved-from Grid48)");
  reset();
}

Grid48Front& Grid48Front::operator=(const Grid48Front& other) {
  // A member-by-member copy that failed halfway would mix two fronts' refined flags and boundary sets.
  if (this != &other) *this = Grid48Front(other);
  return *this;
}

template <class Wants>
void Grid48Front::descend(std::uint32_t ax, std::uint32_t ay, std::uint32_t bx, std::uint32_t by, std::uint32_t cx,
                          std::uint32_t cy, Wants& wants) {
  const std::uint32_t sx = bx + cx, sy = by + cy;
  if (((sx | sy) & 1u) != 0) return;
  const std::uint32_t mx = sx >> 1, my = sy >> 1;
  const Index m = my * static_cast<std::uint32_t>(grid_->lattice_width()) + mx;
  std::uint8_t& state = refined_[m];
  if (state == 0) state = wants(m, mx, my) ? 1 : 2;
  if (state != 1) return;
  descend(mx, my, ax, ay, bx, by, wants);
  descend(mx, my, cx, cy, ax, ay, wants);
}

void Grid48Front::clear_refined() {
  // Output-sensitive reset: after an extract_fast with no move since, only the diamonds it evaluated can
  // be non-zero.
  if (touched_valid_) {
    for (std::size_t i = 0; i < num_touched_; ++i) refined_[touched_[i]] = 0;
  } else {
    std::fill(refined_.begin(), refined_.end(), std::uint8_t{0});
  }
  num_touched_ = 0;
  touched_valid_ = false;
}

void Grid48Front::restore_base() noexcept {
  std::fill(refined_.begin(), refined_.end(), std::uint8_t{0});
  std::fill(slot_.begin(), slot_.end(), kInvalid);
  exposed_.clear();
  maximal_.clear();
  num_touched_ = 0;
  touched_valid_ = true;
  num_refined_ = 0;
  num_faces_ = 2 * grid_->tiles_x() * grid_->tiles_y();
  sets_valid_ = false;
  view_valid_ = false;
}

// The object-error query over the whole grid. Node errors are saturated (a diamond's error is at least
// each child's), so a triangle is split iff its diamond's error exceeds the threshold, whichever of the
// diamond's two triangles gets there first: no memo of rejected diamonds is needed and the result is the
// least fixpoint of extract(). The descent is iterative (depth first, one pending sibling per level).
// Lattice indices are linear in (x, y), so a hypotenuse midpoint is (b + c) / 2, and it is a lattice point
// exactly while the split depth is below 2 log2 S: no coordinates travel with the triangles.
// With kEmit the mesh is written on the way: its vertices are the tile corners and the centres of split
// diamonds, so a vertex is made when its diamond is first split and its id travels down with the
// triangles; a leaf triangle then costs three stores. With kClip (lattice larger than the grid) each
// triangle carries its side of the grid rectangle (0 inside, 1 across its border, 2 outside; only
// triangles across the border are re-classified), vertices are made only for points inside it, and the
// triangles across the border are clipped at the end.
template <bool kClip, bool kEmit>
QueryStats Grid48Front::descend_object(float threshold, TriMesh* out, std::vector<Index>* ids) {
  const Grid48& g = *grid_;
  const std::uint32_t lw = static_cast<std::uint32_t>(g.lattice_width());
  const std::uint32_t xmax = static_cast<std::uint32_t>(g.grid_width() - 1), ymax = static_cast<std::uint32_t>(g.grid_height() - 1);
  const std::uint32_t max_depth = static_cast<std::uint32_t>(2 * g.log2_tile());
  const Grid48::PointRecord* rec = g.records();
  const float sx = g.spacing_x(), sy = g.spacing_y();
  std::uint8_t* refined = refined_.data();
  // The vertex map is left uninitialised (no 4 bytes per lattice point to fill on a fresh front): an entry
  // is read only for points made vertices earlier in this same descent (see the guards below).
  if (kEmit && vertex_id_.size != g.num_points()) {
    vertex_id_.data.reset(new Index[g.num_points()]);
    vertex_id_.size = g.num_points();
  }
  Index* vid = vertex_id_.data.get();
  // Output arrays sized from the error histogram's upper bounds (the refined diamonds are exactly those
  // with error > threshold), written through raw pointers and trimmed at the end: one zero fill instead of
  // a capacity check per push_back. The growth branches are a safety net the bounds make unreachable.
  // (The hot write pointer tp is never captured by a lambda, so that it can stay in a register.)
  std::vector<glm::vec3> pos;
  std::vector<Index> lid, tri;
  std::size_t nv = 0;
  Index* tp = nullptr;  // next triangle slot
  Index* tp_end = nullptr;
  if (kEmit) {
    pos.resize((g.tiles_x() + 1) * (g.tiles_y() + 1) + g.max_refined_above(threshold));
    lid.resize(pos.size());
    tri.resize(3 * g.max_faces_above(threshold));
    tp = tri.data();
    tp_end = tp + tri.size();
  }
  auto inside = [&](Index p) {
    const std::uint32_t y = g.py(p);
    return y <= ymax && p - y * lw <= xmax;
  };
  auto make_vertex = [&](Index p) {
    if (nv == pos.size()) {
      pos.resize(2 * nv);
      lid.resize(2 * nv);
    }
    const std::uint32_t y = g.py(p), x = p - y * lw;
    pos[nv] = {float(x) * sx, float(y) * sy, rec[p].z};
    lid[nv] = p;
    vid[p] = static_cast<Index>(nv);
    return static_cast<Index>(nv++);
  };
  auto side_of = [&](Index a, Index b, Index c) -> std::uint32_t {
    const std::uint32_t ay = g.py(a), by = g.py(b), cy = g.py(c);
    const std::uint32_t ax = a - ay * lw, bx = b - by * lw, cx = c - cy * lw;
    if (std::max({ax, bx, cx}) <= xmax && std::max({ay, by, cy}) <= ymax) return 0;
    if (std::min({ax, bx, cx}) >= xmax || std::min({ay, by, cy}) >= ymax) return 2;
    return 1;
  };
  if (kEmit) {
    const std::size_t s = g.tile_size();
    for (std::size_t ty = 0; ty <= g.tiles_y(); ++ty)
      for (std::size_t tx = 0; tx <= g.tiles_x(); ++tx) {
        const Index p = static_cast<Index>(ty * s * lw + tx * s);
        if (!kClip || inside(p)) make_vertex(p);
      }
  }
  std::vector<Index> across;  // kClip: leaf triangles across the rectangle's border
  std::vector<std::array<Index, 3>> roots;
  roots.reserve(2 * g.tiles_x() * g.tiles_y());
  for_each_root([&](Index a, Index b, Index c) { roots.push_back({a, b, c}); });
  // The current triangle lives in scalars (registers); the stack holds pending second children.
  struct Item {
    Index a, b, c, va, vb, vc;
    std::uint32_t depth_side;  // depth | side << 8
  };
  Item stack[72];
  Index* const touched_begin = touched_.data();
  Index* touched = touched_begin;
  std::size_t faces = 0, finest = 0;
  for (const auto& r : roots) {
    Index a = r[0], b = r[1], c = r[2];
    // Tile corners outside the grid rectangle have no vertex (and no vid entry).
    auto corner_vertex = [&](Index p) -> Index { return kEmit && (!kClip || inside(p)) ? vid[p] : 0; };
    Index va = corner_vertex(a), vb = corner_vertex(b), vc = corner_vertex(c);
    std::uint32_t depth = 0, side = kClip ? side_of(a, b, c) : 0;
    int top = 0;
    for (;;) {
      if (depth < max_depth) {
        const Index m = (b + c) >> 1;
        if (rec[m].error > threshold) {
          // The loads of the next levels are issued now, before the branches that need them resolve:
          // the children's diamonds (b + a) / 2 and (c + a) / 2 and the grandchildren's (m + a, b, c) / 2
          // (indices between lattice points, harmless, when those levels do not exist).
          __builtin_prefetch(rec + ((a + b) >> 1));
          __builtin_prefetch(rec + ((a + c) >> 1));
          __builtin_prefetch(rec + ((m + a) >> 1));
          __builtin_prefetch(rec + ((m + b) >> 1));
          __builtin_prefetch(rec + ((m + c) >> 1));
          Index vm = 0;
          if (!refined[m]) {
            refined[m] = 1;
            *touched++ = m;
            if (kEmit && (!kClip || side == 0 || inside(m))) vm = make_vertex(m);
          } else if (kEmit && (!kClip || side == 0 || inside(m))) {
            // Made by the diamond's other triangle: m is inside the rectangle when this triangle is, and
            // a point inside it was made a vertex whichever side that triangle was on.
            vm = vid[m];
          }
          // Children (m; a, b) and (m; c, a), counter-clockwise; the second waits on the stack.
          Item& w = stack[top++];
          w.a = m;
          w.b = c;
          w.c = a;
          w.va = vm;
          w.vb = vc;
          w.vc = va;
          w.depth_side = (depth + 1) | side << 8;
          c = b;
          b = a;
          a = m;
          vc = vb;
          vb = va;
          va = vm;
          ++depth;
          if (kClip && side == 1) {
            side = side_of(a, b, c);
            Item& u = stack[top - 1];
            u.depth_side = depth | side_of(u.a, u.b, u.c) << 8;
          }
          continue;
        }
      }
      ++faces;
      finest += depth == max_depth;
      if (kEmit) {
        if (!kClip || side == 0) {
          if (tp_end - tp < 3) {
            const std::size_t used = static_cast<std::size_t>(tp - tri.data());
            tri.resize(2 * tri.size());
            tp = tri.data() + used;
            tp_end = tri.data() + tri.size();
          }
          tp[0] = va;
          tp[1] = vb;
          tp[2] = vc;
          tp += 3;
        } else if (side == 1) {
          across.insert(across.end(), {a, b, c});
        }
      }
      if (top == 0) break;
      const Item& u = stack[--top];
      a = u.a;
      b = u.b;
      c = u.c;
      va = u.va;
      vb = u.vb;
      vc = u.vc;
      depth = u.depth_side & 255u;
      side = u.depth_side >> 8;
    }
  }
  const std::size_t split = static_cast<std::size_t>(touched - touched_begin);
  num_touched_ = split;
  if (kEmit) {
    pos.resize(nv);
    lid.resize(nv);
    tri.resize(static_cast<std::size_t>(tp - tri.data()));
    out->positions = std::move(pos);
    out->indices = std::move(tri);
    *ids = std::move(lid);
    if (kClip) {
      GridClipper clipper(g, *out, *ids);
      for (std::size_t k = 0; k < across.size(); k += 3)
        clipper.add(across[k], across[k + 1], across[k + 2], [&](Index p) { return vid[p]; });
    }
  }
  touched_valid_ = true;
  num_refined_ = split;
  num_faces_ = faces;
  sets_valid_ = false;
  view_valid_ = false;
  QueryStats stats;
  stats.refined = split;
  // Every triangle visited was evaluated except the finest leaves: visits = 2 faces - roots.
  stats.evaluated = 2 * faces - roots.size() - finest;
  return stats;
}

TriMesh Grid48Front::extract_mesh(const Query& q, std::vector<Index>* lattice_ids) {
  const bool object = q.criterion.kind() == Criterion::Kind::kObjectError && q.focus.everywhere() &&
                      q.triangle_budget == 0 && q.time_budget_ms <= 0.0;
  if (!object) {
    extract_fast(q);
    try {
      return to_mesh(lattice_ids);
    } catch (...) {
      restore_base();  // as promised for every exception here (only memory can run out in to_mesh)
      throw;
    }
  }
  clear_refined();
  TriMesh out;
  std::vector<Index> ids;
  try {
    if (grid_->needs_clip())
      descend_object<true, true>(q.criterion.threshold(), &out, &ids);
    else
      descend_object<false, true>(q.criterion.threshold(), &out, &ids);
  } catch (...) {
    restore_base();  // the descent had rewritten the front in place (only memory can run out here)
    throw;
  }
  if (lattice_ids) *lattice_ids = std::move(ids);
  return out;
}

QueryStats Grid48Front::extract_fast(const Query& q) {
  q.validate();  // as extract() does: a broken focus set is refused before the front changes
  // The descent marks diamonds in place (1 wanted, 2 evaluated and not), calling the criterion as it
  // goes: if that throws, the marks and counters describe no front, so the front goes back to the base.
  try {
    return extract_fast_unguarded(q);
  } catch (...) {
    restore_base();
    throw;
  }
}

QueryStats Grid48Front::extract_fast_unguarded(const Query& q) {
  if (q.triangle_budget != 0 || q.time_budget_ms > 0.0) return extract(*this, q);
  clear_refined();
  if (q.criterion.kind() == Criterion::Kind::kObjectError && q.focus.everywhere())
    return descend_object<false, false>(q.criterion.threshold(), nullptr, nullptr);
  QueryStats stats;
  const Grid48& g = *grid_;
  const std::uint32_t lw = static_cast<std::uint32_t>(g.lattice_width());
  std::size_t refined = 0, evaluated = 0;
  const float sx = g.spacing_x(), sy = g.spacing_y();
  auto wants = [&](Index m, std::uint32_t mx, std::uint32_t my) {
    ++evaluated;
    touched_[num_touched_++] = m;
    const ElementBound b{{float(mx) * sx, float(my) * sy, g.height_at(m)}, g.radius(m), g.error(m), {}};
    const bool w = q.wants(b);
    refined += w;
    return w;
  };
  for_each_root([&](Index a, Index b, Index c) { descend(a % lw, a / lw, b % lw, b / lw, c % lw, c / lw, wants); });
  std::size_t faces = 2 * g.tiles_x() * g.tiles_y();
  bool ideal = true;
  const bool check = !q.criterion.is_monotone();
  for (std::size_t i = 0; i < num_touched_; ++i) {
    const Index p = touched_[i];
    if (refined_[p] == 2) {
      refined_[p] = 0;
    } else {
      faces += static_cast<std::size_t>(g.num_triangles(p));
      // A parent still marked 2 was rejected by the descent (cleared to 0 only as the loop reaches it):
      // only 1 means refined.
      if (check) g.for_each_parent(p, [&](Index par) { ideal = ideal && refined_[par] == 1; });
    }
  }
  if (!ideal) return extract(*this, q);  // non-monotone criterion: the generic least fixpoint
  touched_valid_ = true;
  num_refined_ = refined;
  num_faces_ = faces;
  sets_valid_ = false;
  view_valid_ = false;
  stats.refined = refined;
  stats.evaluated = evaluated;
  return stats;
}

void ViewQuery::validate() const {
  camera.validate();
  if (!(pixels > 0.0f)) throw InvalidInput("ViewQuery: pixels must be > 0 (got " + std::to_string(pixels) + ")");
  if (!(viewport_height > 0.0f))
    throw InvalidInput("ViewQuery: viewport_height must be > 0 (got " + std::to_string(viewport_height) + ")");
}

Query ViewQuery::to_query() const {
  validate();
  Query q;
  std::vector<Criterion> parts{Criterion::outside_frustum(camera.frustum()),
                               Criterion::screen_error(camera, viewport_height, pixels)};
  if (object_error >= 0.0f) parts.push_back(Criterion::object_error(object_error));
  q.criterion = Criterion::any_of(std::move(parts));
  return q;
}

namespace {

constexpr float kForever = 3.0e38f;
// (v + a) * kShrink < v + a for float rounding of the sum and the product (v, a > 0, normal).
constexpr float kShrink = 1.0f - 0x1p-22f;

// The float nearest to v that is not below (above) it.
float float_up(double v) {
  float f = static_cast<float>(v);
  if (static_cast<double>(f) < v) f = std::nextafter(f, kForever);
  return f;
}
float float_down(double v) {
  float f = static_cast<float>(v);
  if (static_cast<double>(f) > v) f = std::nextafter(f, -kForever);
  return f;
}

}  // namespace

// One frame's view, in the form the evaluations read.
struct Grid48Front::ViewContext {
  Frustum frustum;
  glm::vec3 eye{};
  float object_error = -1.0f;
  float per_pixel = 0.0f;       // pixels per unit at distance one / pixel threshold (Criterion's ratio)
  bool motion_known = false;    // false: no previous frame (the slack is split in halves)
  float step_moved = 0.0f, step_turned = 0.0f;  // this frame's increments
  float moved_up = 0.0f, turned_up = 0.0f;      // accumulated motion now, rounded up
  float moved_down = 0.0f, turned_down = 0.0f;  // and down
  // Lattice point -> centre x, y.
  detail::FastDivider row_of;
  std::uint32_t lw = 1;
  float sx = 1.0f, sy = 1.0f;

  // A record is still valid (its diamond's status cannot have changed since it was made).
  bool holds(const Expiry& x) const noexcept { return moved_up < x.moved && turned_up < x.turned; }
  bool evaluate(const Entry& d, Expiry& x) const noexcept;
};

// Evaluates a diamond for the view and records how much camera motion it can take before its status can
// change. Frustum: each plane's signed distance at the centre moves by at most t + theta * |c - eye| after
// a translation t and a rotation theta of the camera (the planes turn with it); screen error: distance
// minus radius moves by at most t. A diamond is wanted when it is inside the frustum and too coarse on
// screen; it stays unwanted while *either* reason for being unwanted holds (the larger of the two slacks),
// and wanted while both hold (the smaller). Returns "wanted" exactly as Query::wants would (same formulas as
// Criterion::is_fine).
//
// The slack s bounds t + theta * (rho + t) (rho = distance + radius); it is split into a translation
// budget a and a rotation budget b with a + b (rho + a) <= s, in proportion to the last frame's motion (so
// that both run out together if the camera keeps moving the same way), and stored as the accumulated
// motion at which the record expires.
inline bool Grid48Front::ViewContext::evaluate(const Entry& d, Expiry& x) const noexcept {
  const float r = d.radius, e = d.error;
  if (e <= object_error) {  // fine for ever under this view query (errors are >= 0; object_error < 0: unused)
    x = {kForever, kForever};
    return false;
  }
  const std::uint32_t py = row_of.div(d.point), px = d.point - py * lw;
  const glm::vec3 c(float(px) * sx, float(py) * sy, d.z);
  // Frustum: outside if some plane has signed distance < -r, i.e. if the smallest one has.
  const auto& pl = frustum.planes;
  const float s01 = std::min(pl[0].signed_distance(c), pl[1].signed_distance(c));
  const float s23 = std::min(pl[2].signed_distance(c), pl[3].signed_distance(c));
  const float s45 = std::min(pl[4].signed_distance(c), pl[5].signed_distance(c));
  const float nearest = std::min(s01, std::min(s23, s45)) + r;  // < 0: outside by -nearest
  // Screen error: fine when dist - r >= e * per_pixel, decided as Criterion::is_fine does (a zero error
  // is fine, else |c - eye|^2 >= (r + e * per_pixel)^2); room = how far dist - r may fall until not. Where
  // rounding makes the two forms disagree, the slack below is negative and the diamond is re-evaluated.
  const glm::vec3 to_c = c - eye;
  const float dist2 = glm::dot(to_c, to_c);
  const float need = r + e * per_pixel;
  const bool fine = e <= 0.0f || dist2 >= need * need;
  const float dist = std::sqrt(dist2);
  const float room = dist - need;
  const bool wanted = !(nearest < 0.0f) && !fine;
  float slack;
  if (wanted)
    slack = std::min(nearest, -room);
  else
    slack = std::max(-nearest, fine ? (e <= 0.0f ? kForever : room) : -1.0f);
  if (slack >= kForever) {
    x = {kForever, kForever};
    return wanted;
  }
  const float s = slack - 1e-5f * (dist + r + 1.0f);  // margin for the rounding of the tests above
  if (!(s > 0.0f)) {
    x = {};  // re-evaluated next frame
    return wanted;
  }
  // Translation budget a, rotation budget b = what is left: a + b (rho + a) = s. The share of a follows the
  // last frame's motion, so that both run out at about the same time if the camera keeps moving that way;
  // each gets at least 1/64 of the slack (a camera that stops or starts turning costs one evaluation).
  const float rho = dist + r;
  const float share = motion_known ? step_moved / (step_moved + step_turned * (rho + s)) : 0.5f;
  const float a = s * std::clamp(share, 1.0f / 64.0f, 63.0f / 64.0f);
  const float b = (s - a) / (rho + a);
  // The shrink factors absorb the rounding of a, b and a + b (rho + a), and of the stored sums.
  x.moved = (moved_down + a * (1.0f - 0x1p-16f)) * kShrink;
  x.turned = (turned_down + b * (1.0f - 0x1p-16f)) * kShrink;
  return wanted;
}

// How many list items ahead update_view issues the loads of the next items (several refinements' and
// evaluations' cache misses then overlap instead of following one another).
constexpr std::size_t kAhead = 6;

// Evaluates the stale diamonds of a set and appends to `out` those whose status is `pick` (true: wanted).
// The stale indices are found first (a sequential pass over the expiries), then evaluated with each
// entry's load issued kAhead evaluations early. Returns the number of evaluations.
std::size_t Grid48Front::scan_stale(BoundarySet& s, const ViewContext& cx, bool pick, std::vector<Index>& out) {
  std::vector<Index>& stale = view_stale_;
  if (stale.size() < s.size()) stale.resize(s.size());
  // Stale: moved or turned has reached its limit (!holds()).
  const std::size_t n = s.size();
  const float* xs = reinterpret_cast<const float*>(s.expiry.data());  // moved, turned, moved, ...
  Index* st = stale.data();
  const float mu = cx.moved_up, tu = cx.turned_up;
  std::size_t m = 0, i = 0;
#if defined(__SSE2__)
  // Four records per step; most steps find none stale.
  const __m128 limit = _mm_setr_ps(mu, tu, mu, tu);
  for (; i + 4 <= n; i += 4) {
    const int lo = _mm_movemask_ps(_mm_cmple_ps(_mm_loadu_ps(xs + 2 * i), limit));
    const int hi = _mm_movemask_ps(_mm_cmple_ps(_mm_loadu_ps(xs + 2 * i + 4), limit));
    const int bits = lo | hi << 4;  // bits 2j, 2j + 1: record i + j
    if (bits == 0) continue;
    for (int j = 0; j < 4; ++j) {
      st[m] = static_cast<Index>(i + static_cast<std::size_t>(j));
      m += ((bits >> (2 * j)) & 3) != 0;
    }
  }
#endif
  for (; i < n; ++i) {
    st[m] = static_cast<Index>(i);
    m += (xs[2 * i] <= mu) | (xs[2 * i + 1] <= tu);
  }
  for (std::size_t k = 0; k < m; ++k) {
    if (k + kAhead < m) {
      __builtin_prefetch(&s.entry[stale[k + kAhead]]);
      __builtin_prefetch(&s.expiry[stale[k + kAhead]], 1);
    }
    const Index j = stale[k];
    if (cx.evaluate(s.entry[j], s.expiry[j]) == pick) out.push_back(s.entry[j].point);
  }
  return m;
}

// The entry of p in s, once slot_[p] has arrived (its load issued by prefetch_refine or prefetch_coarsen).
void Grid48Front::prefetch_entry(const BoundarySet& s, Index p) const {
  const Index i = slot_[p];
  if (i < s.size()) {
    __builtin_prefetch(&s.entry[i]);
    __builtin_prefetch(&s.expiry[i]);
  }
}

// The loads on_refined(p) and refine(p) will make (p exposed: its parents are refined).
void Grid48Front::prefetch_refine(Index p) const {
  const Grid48& g = *grid_;
  const Grid48::Family f = g.family(p);
  __builtin_prefetch(&slot_[p]);
  for (int k = 0; k < f.num_parents; ++k) {
    __builtin_prefetch(&refined_[f.parent[k]]);
    __builtin_prefetch(&slot_[f.parent[k]]);
  }
  for (int k = 0; k < f.num_children; ++k) {
    __builtin_prefetch(&slot_[f.child[k]]);
    __builtin_prefetch(g.records() + f.child[k]);
    __builtin_prefetch(g.radii() + f.child[k]);
  }
}

// The loads on_coarsened(p) will make (p maximal).
void Grid48Front::prefetch_coarsen(Index p) const {
  const Grid48& g = *grid_;
  const Grid48::Family f = g.family(p);
  __builtin_prefetch(&slot_[p]);
  for (int k = 0; k < f.num_parents; ++k) {
    const Index q = f.parent[k];
    __builtin_prefetch(&slot_[q]);
    __builtin_prefetch(g.records() + q);
    __builtin_prefetch(g.radii() + q);
    g.for_each_child(q, [&](Index c) { __builtin_prefetch(&refined_[c]); });
  }
  for (int k = 0; k < f.num_children; ++k) {
    __builtin_prefetch(&slot_[f.child[k]]);
    if (f.co_parent[k] != kInvalid) __builtin_prefetch(&refined_[f.co_parent[k]]);
  }
}

QueryStats Grid48Front::update_view(const ViewQuery& v) {
  v.validate();
  // The motion between frames reads the view matrices: one that overflows float (eye and target ~1e19
  // apart) is refused here, before anything changes, rather than by the next frame.
  static_cast<void>(v.camera.view());
  try {
    return update_view_unguarded(v);
  } catch (...) {
    // Stopped between two moves: the front is valid, but the records of the diamonds evaluated and not yet
    // moved no longer describe it, so the next call starts afresh.
    new_exposed_ = nullptr;
    new_maximal_ = nullptr;
    carry_records_ = false;
    view_valid_ = false;
    throw;
  }
}

QueryStats Grid48Front::update_view_unguarded(const ViewQuery& v) {
  const ViewQuery& o = last_view_;
  const bool same_params = view_valid_ && o.viewport_height == v.viewport_height && o.pixels == v.pixels &&
                           o.object_error == v.object_error && o.camera.fov_y_deg == v.camera.fov_y_deg &&
                           o.camera.aspect == v.camera.aspect && o.camera.z_near == v.camera.z_near &&
                           o.camera.z_far == v.camera.z_far;
  if (!sets_valid_) rebuild_sets();
  if (!same_params) {
    // Everything is re-evaluated: forget every record (they were made for other parameters).
    std::fill(exposed_.expiry.begin(), exposed_.expiry.end(), Expiry{});
    std::fill(maximal_.expiry.begin(), maximal_.expiry.end(), Expiry{});
    moved_ = turned_ = 0.0;
    step_moved_ = step_turned_ = 0.0f;
  } else {
    step_moved_ = glm::length(v.camera.eye - o.camera.eye);
    // Rotation between the two view frames, as an angle (geodesic distance on SO(3)): |R - I|_F =
    // 2 sqrt(2) sin(angle / 2), in double. The trace formula acos((tr R - 1) / 2) in float read a 1e-4 rad
    // turn as 1e-6 (acos is flat near 1), so slow pans kept records past their expiry.
    const glm::dmat3 ra(glm::mat3(o.camera.view())), rb(glm::mat3(v.camera.view()));
    const glm::dmat3 rel = glm::transpose(ra) * rb;
    double f2 = 0.0;
    for (int c = 0; c < 3; ++c)
      for (int r = 0; r < 3; ++r) {
        const double d = rel[c][r] - (c == r ? 1.0 : 0.0);
        f2 += d * d;
      }
    step_turned_ = static_cast<float>(2.0 * std::asin(std::min(1.0, std::sqrt(f2) / (2.0 * std::sqrt(2.0))))) + 1e-6f;
    moved_ += double(step_moved_);
    turned_ += double(step_turned_);
  }
  last_view_ = v;
  view_valid_ = true;
  ViewContext cx;
  cx.frustum = v.camera.frustum();
  cx.eye = v.camera.eye;
  cx.per_pixel = v.camera.pixels_per_unit_at_distance_one(v.viewport_height) / v.pixels;
  cx.motion_known = same_params;
  cx.object_error = v.object_error;
  cx.step_moved = step_moved_;
  cx.step_turned = step_turned_;
  cx.moved_up = float_up(moved_);
  cx.turned_up = float_up(turned_);
  cx.moved_down = float_down(moved_);
  cx.turned_down = float_down(turned_);
  cx.row_of = detail::FastDivider(static_cast<std::uint32_t>(grid_->lattice_width()));
  cx.lw = static_cast<std::uint32_t>(grid_->lattice_width());
  cx.sx = grid_->spacing_x();
  cx.sy = grid_->spacing_y();
  QueryStats stats;
  std::vector<Index>& work = view_work_;
  std::vector<Index>& fresh = view_new_;
  carry_records_ = true;
  // Coarsen. Stale maximal diamonds are evaluated in place (a sequential scan); those no longer wanted are
  // coarsened afterwards (which never changes another's status). A diamond whose record still holds keeps
  // its status, so after the scan only diamonds that become maximal during this frame (parents of
  // coarsened ones) need an evaluation. A coarsened diamond takes its record ("not wanted") to the exposed
  // set.
  work.clear();
  fresh.clear();
  stats.evaluated += scan_stale(maximal_, cx, false, work);
  new_maximal_ = &fresh;
  for (std::size_t k = 0; k < work.size(); ++k) {
    if (k + kAhead < work.size()) prefetch_coarsen(work[k + kAhead]);
    if (k + kAhead / 2 < work.size()) prefetch_entry(maximal_, work[k + kAhead / 2]);
    coarsen_unchecked(work[k]);
    ++stats.coarsened;
  }
  while (!fresh.empty()) {
    const Index p = fresh.back();
    fresh.pop_back();
    const Index i = slot_[p];
    if (!refined_[p] || i == kInvalid || cx.holds(maximal_.expiry[i])) continue;
    ++stats.evaluated;
    if (cx.evaluate(maximal_.entry[i], maximal_.expiry[i])) continue;
    coarsen_unchecked(p);
    ++stats.coarsened;
  }
  new_maximal_ = nullptr;
  // Refine. Stale exposed diamonds are evaluated in place; the wanted ones are refined afterwards (with
  // their missing ancestors), taking their records ("wanted") to the maximal set, and the diamonds they
  // newly expose are evaluated in turn.
  work.clear();
  stats.evaluated += scan_stale(exposed_, cx, true, work);
  new_exposed_ = &fresh;
  auto refine_wanted = [&](Index p) { refine(p, [&](Index) { ++stats.refined; }); };
  for (std::size_t k = 0; k < work.size(); ++k) {
    if (k + kAhead < work.size()) prefetch_refine(work[k + kAhead]);
    if (k + kAhead / 2 < work.size()) prefetch_entry(exposed_, work[k + kAhead / 2]);
    refine_wanted(work[k]);
  }
  while (!fresh.empty()) {
    const Index p = fresh.back();
    fresh.pop_back();
    const Index i = slot_[p];
    if (refined_[p] || i == kInvalid || cx.holds(exposed_.expiry[i])) continue;
    ++stats.evaluated;
    if (cx.evaluate(exposed_.entry[i], exposed_.expiry[i])) refine_wanted(p);
  }
  new_exposed_ = nullptr;
  carry_records_ = false;
  return stats;
}

void Grid48Front::reset() {
  // The arrays keep their size (they allocate only on a moved-from front). If making room for the tile
  // centres throws, the front is the base mesh with its boundary sets left to be rebuilt.
  sets_valid_ = false;
  view_valid_ = false;
  refined_.assign(grid_->num_points(), 0);
  touched_.resize(grid_->num_points());
  num_touched_ = 0;
  touched_valid_ = true;  // nothing is marked: the next clear_refined has nothing to clear
  num_refined_ = 0;
  num_faces_ = 2 * grid_->tiles_x() * grid_->tiles_y();
  exposed_.clear();
  maximal_.clear();
  slot_.assign(grid_->num_points(), kInvalid);
  const std::size_t s = grid_->tile_size(), w = grid_->lattice_width();
  for (std::size_t ty = 0; ty < grid_->tiles_y(); ++ty)
    for (std::size_t tx = 0; tx < grid_->tiles_x(); ++tx) {
      const Index p = static_cast<Index>((ty * s + s / 2) * w + tx * s + s / 2);
      if (lacks_room(exposed_, 1)) make_room(exposed_, 1);
      set_add(exposed_, entry_of(p), {});
    }
  sets_valid_ = true;
}

// Callers make room first (make_room), so the push_backs do not throw.
void Grid48Front::set_add(BoundarySet& s, const Entry& e, Expiry x) {
  VARMESH_ASSERT(!lacks_room(s, 1));
  slot_[e.point] = static_cast<Index>(s.entry.size());
  s.entry.push_back(e);
  s.expiry.push_back(x);
}

// Capacities double, as push_back's would (the same sizes in the same order: the allocator reuses blocks as
// it did). Each reserve has the strong guarantee: if the second throws, the first only left spare room.
void Grid48Front::make_room(BoundarySet& s, std::size_t extra) {
  auto grow = [extra](auto& v) {
    if (spare(v) < extra) v.reserve(std::max(v.size() + extra, 2 * v.capacity()));
  };
  grow(s.entry);
  grow(s.expiry);
}

void Grid48Front::make_room(std::size_t exposed, std::size_t maximal, std::vector<Index>* added, std::size_t listed) {
  make_room(exposed_, exposed);
  make_room(maximal_, maximal);
  if (spare(added) < listed) added->reserve(std::max(added->size() + listed, 2 * added->capacity()));
}

inline void Grid48Front::set_remove(BoundarySet& s, Index p) {
  const Index i = slot_[p];
  const Index last = static_cast<Index>(s.entry.size() - 1);
  if (i != last) {
    s.entry[i] = s.entry[last];
    s.expiry[i] = s.expiry[last];
    slot_[s.entry[i].point] = i;
  }
  s.entry.pop_back();
  s.expiry.pop_back();
  slot_[p] = kInvalid;
}

void Grid48Front::rebuild_sets() {
  // The stale sets still match slot_ (nothing but extract_fast changed refined_ since they were valid):
  // small ones are cleared entry by entry, large ones by a fill of the whole lattice (sequential).
  if ((exposed_.size() + maximal_.size()) >= slot_.size() / 8) {
    std::fill(slot_.begin(), slot_.end(), kInvalid);
  } else {
    for (const Entry& e : exposed_.entry) slot_[e.point] = kInvalid;
    for (const Entry& e : maximal_.entry) slot_[e.point] = kInvalid;
  }
  exposed_.clear();
  maximal_.clear();
  // If making room throws, the partial sets still match slot_ (what the next rebuild clears).
  for_each_boundary(
      [&](Index p) {
        if (lacks_room(exposed_, 1)) make_room(exposed_, 1);
        set_add(exposed_, entry_of(p), {});
      },
      [&](Index p) {
        if (lacks_room(maximal_, 1)) make_room(maximal_, 1);
        set_add(maximal_, entry_of(p), {});
      });
  sets_valid_ = true;
}

// t is exposed (every parent refined) and becomes refined: it moves to the maximal set (with its record
// when update_view refines it because it is wanted), its parents leave it, its new children are exposed.
// The slot of a refined point refers to maximal_, of an unrefined one to exposed_. Room in the sets is made
// first: if that throws, nothing has changed.
void Grid48Front::on_refined(Index t) {
  make_room_to_refine();
  refined_[t] = 1;
  touched_valid_ = false;
  const Grid48::Family f = grid_->family(t);
  const Index i = slot_[t];
  Entry e;
  Expiry x;
  if (i != kInvalid) {
    e = exposed_.entry[i];
    if (carry_records_ && t == refine_target_) x = exposed_.expiry[i];
    set_remove(exposed_, t);
  } else {
    e = entry_of(t);
  }
  set_add(maximal_, e, x);
  for (int k = 0; k < f.num_parents; ++k)
    if (slot_[f.parent[k]] != kInvalid) set_remove(maximal_, f.parent[k]);
  for (int k = 0; k < f.num_children; ++k) {
    const Index c = f.child[k];
    if (slot_[c] != kInvalid) continue;
    set_add(exposed_, entry_of(c), {});
    if (new_exposed_) new_exposed_->push_back(c);
  }
}

// t was maximal and is now unrefined: it moves to the exposed set (with its record when update_view
// coarsens it because it is not wanted), parents left without a refined child become maximal, children
// without a refined parent stop being exposed.
void Grid48Front::on_coarsened(Index t) {
  const Grid48& g = *grid_;
  const Grid48::Family f = g.family(t);
  const Index i = slot_[t];
  Entry e;
  Expiry x;
  if (i != kInvalid) {
    e = maximal_.entry[i];
    if (carry_records_) x = maximal_.expiry[i];
    set_remove(maximal_, t);
  } else {
    e = entry_of(t);
  }
  set_add(exposed_, e, x);
  for (int k = 0; k < f.num_parents; ++k) {
    const Index q = f.parent[k];
    if (slot_[q] != kInvalid) continue;
    if (g.has_refined_child(q, refined_.data())) continue;
    set_add(maximal_, entry_of(q), {});
    if (new_maximal_) new_maximal_->push_back(q);
  }
  for (int k = 0; k < f.num_children; ++k) {
    const Index c = f.child[k];
    if (slot_[c] == kInvalid) continue;
    // c's parents are t (now unrefined) and its mirror image through c.
    if (f.co_parent[k] == kInvalid || !refined_[f.co_parent[k]]) set_remove(exposed_, c);
  }
}

inline void Grid48Front::coarsen_unchecked(Index p) {
  if (!sets_valid_) rebuild_sets();
  make_room_to_coarsen();  // may throw: nothing has changed for p yet
  refined_[p] = 0;
  touched_valid_ = false;
  on_coarsened(p);
  --num_refined_;
  num_faces_ -= static_cast<std::size_t>(grid_->num_triangles(p));
}

void Grid48Front::check_diamond(Index p, const char* who) const {
  if (p >= grid_->num_points() || !grid_->is_node(p))
    throw InvalidInput(std::string("Grid48Front::") + who + ": " + std::to_string(p) +
                           (p >= grid_->num_points() ? " is out of range" : " is a tile corner, not a diamond"),
                       p);
}

void Grid48Front::coarsen_one(Index p) {
  check_diamond(p, "coarsen_one");
  if (!is_coarsenable(p))
    throw InvalidInput("Grid48Front::coarsen_one: diamond " + std::to_string(p) +
                           (refined_[p] ? " has a refined child" : " is not refined"),
                       p);
  coarsen_unchecked(p);
}

void Grid48Front::validate() const {
  std::size_t refined = 0, faces = 2 * grid_->tiles_x() * grid_->tiles_y();
  for (Index p = 0; p < grid_->num_points(); ++p) {
    if (!refined_[p]) continue;
    if (!grid_->is_node(p)) throw InvalidInput("Grid48Front::validate: a tile corner is marked refined", p);
    ++refined;
    faces += static_cast<std::size_t>(grid_->num_triangles(p));
    grid_->for_each_parent(p, [&](Index q) {
      if (!refined_[q]) throw InvalidInput("Grid48Front::validate: diamond refined before its parent " + std::to_string(q), p);
    });
  }
  if (refined != num_refined_ || faces != num_faces_) throw InvalidInput("Grid48Front::validate: stale counters");
  std::size_t walked = 0;
  for_each_triangle([&](Index, Index, Index) { ++walked; });
  if (walked != num_faces_) throw InvalidInput("Grid48Front::validate: triangle walk disagrees with the face count");
}


TriMesh Grid48Front::to_mesh(std::vector<Index>* lattice_ids) const {
  const std::size_t n = grid_->num_points();
  // Borrow the front's map (all kInvalid while not borrowed); a concurrent call fills its own.
  if (vertex_map_.busy.exchange(true, std::memory_order_acquire)) {
    std::vector<Index> own(n, kInvalid);
    return to_mesh_with(own.data(), lattice_ids);
  }
  std::vector<Index>& remap = vertex_map_.map;
  try {
    if (remap.size() != n) remap.assign(n, kInvalid);
    TriMesh out = to_mesh_with(remap.data(), lattice_ids);
    vertex_map_.busy.store(false, std::memory_order_release);
    return out;
  } catch (...) {
    std::fill(remap.begin(), remap.end(), kInvalid);  // entries the interrupted call had set
    vertex_map_.busy.store(false, std::memory_order_release);
    throw;
  }
}

TriMesh Grid48Front::to_mesh_with(Index* remap, std::vector<Index>* lattice_ids) const {
  TriMesh out;
  const Grid48& g = *grid_;
  const std::size_t lw = g.lattice_width();
  std::vector<Index> ids;
  ids.reserve(num_faces_ / 2 + 16);
  out.positions.reserve(num_faces_ / 2 + 16);
  auto lattice_vertex = [&](Index p) {
    Index& slot = remap[p];
    if (slot == kInvalid) {
      slot = static_cast<Index>(out.positions.size());
      out.positions.push_back(g.position(p));
      ids.push_back(p);
    }
    return slot;
  };
  out.indices.reserve(num_faces_ * 3);
  if (!g.needs_clip()) {
    // The hot path: indices written into a pre-sized array, positions from the lattice coordinates.
    out.indices.resize(3 * num_faces_);
    Index* dst = out.indices.data();
    const std::uint32_t lwi = static_cast<std::uint32_t>(lw);
    const float sxs = g.spacing_x(), sys = g.spacing_y();
    auto vertex = [&](Index p) {
      Index& slot = remap[p];
      if (slot == kInvalid) {
        slot = static_cast<Index>(out.positions.size());
        const std::uint32_t y = g.py(p), x = p - y * lwi;
        out.positions.push_back({float(x) * sxs, float(y) * sys, g.height_at(p)});
        ids.push_back(p);
      }
      return slot;
    };
    for_each_triangle([&](Index a, Index b, Index c) {
      dst[0] = vertex(a);
      dst[1] = vertex(b);
      dst[2] = vertex(c);
      dst += 3;
    });
  } else {
    GridClipper clipper(g, out, ids);
    for_each_triangle([&](Index a, Index b, Index c) { clipper.add(a, b, c, lattice_vertex); });
  }
  for (Index p : ids)
    if (p != kInvalid) remap[p] = kInvalid;
  if (lattice_ids) *lattice_ids = std::move(ids);
  return out;
}

}  // namespace varmesh
