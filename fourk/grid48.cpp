#include "fourk/grid48.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <string>
#include <unordered_map>

#include "multitri/errors.hpp"

namespace varmesh {
namespace {

struct P2 {
  std::ptrdiff_t x, y;
};

// Largest |h - plane| over the grid samples inside the closed triangle (a, b, c) (lattice coordinates,
// right isosceles so every edge is axis-aligned or diagonal: row intersections are integers), restricted to
// samples with x < w, y < h. The plane interpolates the lattice heights at the corners.
double triangle_error(const float* z, std::size_t lw, std::size_t w, std::size_t h, P2 a, P2 b, P2 c) {
  const double za = z[a.y * static_cast<std::ptrdiff_t>(lw) + a.x];
  const double zb = z[b.y * static_cast<std::ptrdiff_t>(lw) + b.x];
  const double zc = z[c.y * static_cast<std::ptrdiff_t>(lw) + c.x];
  const double e1x = double(b.x - a.x), e1y = double(b.y - a.y), e2x = double(c.x - a.x), e2y = double(c.y - a.y);
  const double det = e1x * e2y - e2x * e1y;
  const double gx = ((zb - za) * e2y - (zc - za) * e1y) / det;
  const double gy = ((zc - za) * e1x - (zb - za) * e2x) / det;
  const std::ptrdiff_t ymin = std::min({a.y, b.y, c.y});
  const std::ptrdiff_t ymax = std::min<std::ptrdiff_t>(std::max({a.y, b.y, c.y}), static_cast<std::ptrdiff_t>(h) - 1);
  const std::array<P2, 3> v{a, b, c};
  double worst = 0.0;
  for (std::ptrdiff_t y = ymin; y <= ymax; ++y) {
    std::ptrdiff_t lo = PTRDIFF_MAX, hi = PTRDIFF_MIN;
    for (int k = 0; k < 3; ++k) {
      const P2 p = v[k], q = v[(k + 1) % 3];
      if (y < std::min(p.y, q.y) || y > std::max(p.y, q.y)) continue;
      if (p.y == q.y) {
        lo = std::min({lo, p.x, q.x});
        hi = std::max({hi, p.x, q.x});
      } else {
        const std::ptrdiff_t x = p.x + (y - p.y) * (q.x - p.x) / (q.y - p.y);
        lo = std::min(lo, x);
        hi = std::max(hi, x);
      }
    }
    hi = std::min<std::ptrdiff_t>(hi, static_cast<std::ptrdiff_t>(w) - 1);
    const float* row = z + y * static_cast<std::ptrdiff_t>(lw);
    const double base = za + gy * double(y - a.y) - gx * double(a.x);
    for (std::ptrdiff_t x = lo; x <= hi; ++x) {
      const double d = std::abs(double(row[x]) - (base + gx * double(x)));
      worst = std::max(worst, d);
    }
  }
  return worst;
}

float round_up(double v) {
  float f = static_cast<float>(v);
  if (static_cast<double>(f) < v) f = std::nextafter(f, 3.0e38f);
  return f;
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
    if ((s & (s - 1)) != 0 || s < 2) throw InvalidInput("Grid48: tile_size must be a power of two >= 2");
  } else {
    // The largest tile whose padding stays within max_padding (at least 2 cells).
    const double area = double(cw) * double(ch);
    s = 2;
    for (std::size_t t = 4; t <= (std::size_t(1) << 15) && t / 2 < std::max(cw, ch); t *= 2) {
      const auto [tx, ty] = padded(t);
      if (double(tx * t) * double(ty * t) <= options.max_padding * area) s = t;
    }
  }
  tile_ = s;
  log2_tile_ = grid48_detail::ctz(s);
  std::tie(tx_, ty_) = padded(s);
  lw_ = tx_ * s + 1;
  lh_ = ty_ * s + 1;
  if (double(lw_) * double(lh_) > double(1u << 30)) throw InvalidInput("Grid48: grid too large (more than 2^30 lattice points)");
  z_.resize(lw_ * lh_);
  for (std::size_t y = 0; y < lh_; ++y) {
    const std::size_t yy = std::min(y, height_ - 1);
    for (std::size_t x = 0; x < lw_; ++x) z_[y * lw_ + x] = field.z[yy * width_ + std::min(x, width_ - 1)];
  }
  compute_errors();
  compute_radii();
}

std::size_t Grid48::num_nodes() const noexcept { return lw_ * lh_ - (tx_ + 1) * (ty_ + 1); }

std::size_t Grid48::memory_bytes() const noexcept {
  return (z_.size() + error_.size() + radius_.size()) * sizeof(float);
}

void Grid48::compute_errors() {
  error_.assign(lw_ * lh_, 0.0f);
  const std::ptrdiff_t w = static_cast<std::ptrdiff_t>(lw_), h = static_cast<std::ptrdiff_t>(lh_);
  auto own_error = [&](Index p) {
    const std::ptrdiff_t x = p % w, y = p / w;
    const int lx = grid48_detail::ctz(static_cast<std::size_t>(x)), ly = grid48_detail::ctz(static_cast<std::size_t>(y));
    double e = 0.0;
    if (lx == ly) {
      const std::ptrdiff_t d = std::ptrdiff_t(1) << lx;
      const std::ptrdiff_t cx = ((x - d) / (2 * d)) % 2 != 0 ? x - d : x + d;
      const std::ptrdiff_t cy = ((y - d) / (2 * d)) % 2 != 0 ? y - d : y + d;
      const P2 c0{cx, cy}, c1{2 * x - cx, 2 * y - cy};
      e = std::max(triangle_error(z_.data(), lw_, width_, height_, {2 * x - cx, cy}, c0, c1),
                   triangle_error(z_.data(), lw_, width_, height_, {cx, 2 * y - cy}, c0, c1));
    } else {
      const std::ptrdiff_t d = std::ptrdiff_t(1) << std::min(lx, ly);
      const bool horizontal = lx < ly;
      const P2 e0 = horizontal ? P2{x - d, y} : P2{x, y - d};
      const P2 e1 = horizontal ? P2{x + d, y} : P2{x, y + d};
      const P2 a0 = horizontal ? P2{x, y - d} : P2{x - d, y};
      const P2 a1 = horizontal ? P2{x, y + d} : P2{x + d, y};
      if (a0.x >= 0 && a0.y >= 0) e = std::max(e, triangle_error(z_.data(), lw_, width_, height_, a0, e0, e1));
      if (a1.x < w && a1.y < h) e = std::max(e, triangle_error(z_.data(), lw_, width_, height_, a1, e0, e1));
    }
    return e;
  };
  // Finest level first so that children are saturated before their parents.
  for (int ld = 0; ld < log2_tile_; ++ld) {
    const std::ptrdiff_t d = std::ptrdiff_t(1) << ld;
    for (int pass = 0; pass < 2; ++pass) {  // pass 0: edge diamonds of size d; pass 1: square diamonds
      for (std::ptrdiff_t y = 0; y < h; y += d) {
        const bool yodd = ((y / d) & 1) != 0;
        for (std::ptrdiff_t x = (pass == 1 || !yodd) ? d : 0; x < w; x += 2 * d) {
          const bool xodd = ((x / d) & 1) != 0;
          if (pass == 0 && xodd == yodd) continue;
          if (pass == 1 && !(xodd && yodd)) continue;
          const Index p = static_cast<Index>(y * w + x);
          double e = own_error(p);
          float sat = round_up(e);
          for_each_child(p, [&](Index c) { sat = std::max(sat, error_[c]); });
          error_[p] = sat;
        }
      }
    }
  }
}

void Grid48::compute_radii() {
  radius_.assign(lw_ * lh_, 0.0f);
  const std::ptrdiff_t w = static_cast<std::ptrdiff_t>(lw_), h = static_cast<std::ptrdiff_t>(lh_);
  for (int ld = 0; ld < log2_tile_; ++ld) {
    const std::ptrdiff_t d = std::ptrdiff_t(1) << ld;
    for (int pass = 0; pass < 2; ++pass) {
      for (std::ptrdiff_t y = 0; y < h; y += d) {
        const bool yodd = ((y / d) & 1) != 0;
        for (std::ptrdiff_t x = (pass == 1 || !yodd) ? d : 0; x < w; x += 2 * d) {
          const bool xodd = ((x / d) & 1) != 0;
          if (pass == 0 && xodd == yodd) continue;
          if (pass == 1 && !(xodd && yodd)) continue;
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
        }
      }
    }
  }
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
  for (Index m : nodes) b.add_node(NodeKind::kSplit, removed[m], created[m], error_[m]);
  return std::move(b).build();
}

double Grid48::max_vertical_error(const TriMesh& mesh) const {
  std::vector<std::uint8_t> covered(width_ * height_, 0);
  double worst = 0.0;
  for (std::size_t f = 0; f < mesh.num_faces(); ++f) {
    glm::dvec3 v[3];
    for (int k = 0; k < 3; ++k) {
      const glm::vec3 p = mesh.positions[mesh.corner(f, k)];
      v[k] = {double(p.x) / sx_, double(p.y) / sy_, double(p.z)};
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
        worst = std::max(worst, std::abs(zi - double(z_[static_cast<std::size_t>(y) * lw_ + static_cast<std::size_t>(x)])));
      }
  }
  for (std::uint8_t c : covered)
    if (!c) return HUGE_VAL;  // a hole: some sample is not under any triangle
  return worst;
}

Grid48Front::Grid48Front(const Grid48& grid) : grid_(&grid) { reset(); }

void Grid48Front::reset() {
  refined_.assign(grid_->num_points(), 0);
  num_refined_ = 0;
  num_faces_ = 2 * grid_->tiles_x() * grid_->tiles_y();
}

void Grid48Front::coarsen_one(Index p) {
  if (!is_coarsenable(p))
    throw InvalidInput("Grid48Front::coarsen_one: diamond " + std::to_string(p) +
                           (refined_[p] ? " has a refined child" : " is not refined"),
                       p);
  refined_[p] = 0;
  --num_refined_;
  num_faces_ -= static_cast<std::size_t>(grid_->num_triangles(p));
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

}  // namespace

TriMesh Grid48Front::to_mesh(std::vector<Index>* lattice_ids) const {
  TriMesh out;
  const Grid48& g = *grid_;
  const std::size_t lw = g.lattice_width();
  std::unordered_map<Index, Index> remap;
  remap.reserve(num_faces_);
  std::vector<Index> ids;
  auto lattice_vertex = [&](Index p) {
    auto [it, inserted] = remap.try_emplace(p, static_cast<Index>(out.positions.size()));
    if (inserted) {
      out.positions.push_back(g.position(p));
      ids.push_back(p);
    }
    return it->second;
  };
  out.indices.reserve(num_faces_ * 3);
  if (!g.needs_clip()) {
    for_each_triangle([&](Index a, Index b, Index c) {
      out.indices.push_back(lattice_vertex(a));
      out.indices.push_back(lattice_vertex(b));
      out.indices.push_back(lattice_vertex(c));
    });
  } else {
    const double xmax = double(g.grid_width() - 1), ymax = double(g.grid_height() - 1);
    std::unordered_map<std::uint64_t, Index> clip_vertices;
    auto clip_vertex = [&](const CV& v) {
      float fx = static_cast<float>(v.x), fy = static_cast<float>(v.y);
      std::uint32_t bx, by;
      std::memcpy(&bx, &fx, 4);
      std::memcpy(&by, &fy, 4);
      auto [it, inserted] = clip_vertices.try_emplace((std::uint64_t(bx) << 32) | by, static_cast<Index>(out.positions.size()));
      if (inserted) {
        out.positions.push_back({fx * g.spacing_x(), fy * g.spacing_y(), static_cast<float>(v.z)});
        ids.push_back(kInvalid);
      }
      return it->second;
    };
    std::vector<CV> poly, tmp;
    auto cv = [&](Index p) {
      return CV{double(p % lw), double(p / lw), double(g.position(p).z), p};
    };
    for_each_triangle([&](Index a, Index b, Index c) {
      const CV va = cv(a), vb = cv(b), vc = cv(c);
      if (std::max({va.x, vb.x, vc.x}) <= xmax && std::max({va.y, vb.y, vc.y}) <= ymax) {
        out.indices.push_back(lattice_vertex(a));
        out.indices.push_back(lattice_vertex(b));
        out.indices.push_back(lattice_vertex(c));
        return;
      }
      if (std::min({va.x, vb.x, vc.x}) >= xmax || std::min({va.y, vb.y, vc.y}) >= ymax) return;
      poly.assign({va, vb, vc});
      clip(poly, tmp, true, xmax);
      if (poly.size() >= 3) clip(poly, tmp, false, ymax);
      if (poly.size() < 3) return;
      Index vid[8];
      for (std::size_t k = 0; k < poly.size(); ++k)
        vid[k] = poly[k].lattice != kInvalid ? lattice_vertex(poly[k].lattice) : clip_vertex(poly[k]);
      // Fan from a vertex that makes no zero-area triangle (clipped polygons can have three collinear
      // vertices on a clipping line; fanning from the middle one keeps every vertex, so no T-junction).
      const std::size_t n = poly.size();
      auto area = [&](std::size_t i, std::size_t j, std::size_t k) {
        return (poly[j].x - poly[i].x) * (poly[k].y - poly[i].y) - (poly[k].x - poly[i].x) * (poly[j].y - poly[i].y);
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
        out.indices.push_back(vid[apex]);
        out.indices.push_back(vid[j]);
        out.indices.push_back(vid[l]);
      }
    });
  }
  if (lattice_ids) *lattice_ids = std::move(ids);
  return out;
}

}  // namespace varmesh
