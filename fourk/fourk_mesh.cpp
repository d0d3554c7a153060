// The hierarchical 4-k structure in index form.
//
// Paper: L. Velho, J. Gomes, "Variable resolution 4-k meshes" (2000), section 7.1 (the Face / Hedge
// structures, pre_image_w, image_w, successor_f, predecessor_f, modification_type) and 7.2 (split and
// swap nodes of the DAG). The paper shares one Hedge between a parent and the child that inherits its
// edge; with the stride layout (half-edges of face f at 3f..3f+2) every face owns its half-edges, so a
// child *adopts* its parent's outer half-edge: it takes over the mate link, and the parent keeps only
// the link across its split edge, which is all that pre_image_w needs.
#include "fourk/fourk_mesh.hpp"

#include <algorithm>
#include <cmath>
#include <string>
#include <utility>

#include "fourk/poly_mesh.hpp"
#include "multitri/errors.hpp"

namespace varmesh {

namespace {


std::string he_name(HalfEdgeId h) {
  return "half-edge " + std::to_string(h) + " (face " + std::to_string(h / 3) + ", edge " + std::to_string(h % 3) + ")";
}

bool finite(const glm::vec3& p) { return std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z); }

// Half-edge ids are 32-bit: 3 * faces must stay below kInvalid.
constexpr std::size_t kMaxFaces = (std::size_t(kInvalid) - 3) / 3;

}  // namespace

FourKMesh::FourKMesh(const TriMesh& base) {
  base.validate();
  const std::size_t nf = base.num_faces();
  if (nf == 0) throw InvalidInput("FourKMesh: the base mesh has no face (empty mesh)");
  if (nf > kMaxFaces) throw InvalidInput("FourKMesh: too many faces for 32-bit half-edge ids");
  // The rules live in find_topology_problem (poly_mesh.hpp), so that the command line can say the same
  // problem in a file's terms. Its opposite sides are the mates: half-edge 3f + k is its slot 3f + k.
  std::vector<HalfEdgeId> opposite;
  if (const TopologyProblem problem = find_topology_problem(base, kFourKMeshRules, &opposite))
    throw InvalidInput("FourKMesh: " + describe_topology_problem(problem), problem.element());
  positions_ = base.positions;
  point_.assign(base.indices.begin(), base.indices.end());
  mate_ = std::move(opposite);
  parent_.assign(nf, kInvalid);
  children_.assign(2 * nf, kInvalid);
  error_.assign(nf, 0.0f);
  num_base_faces_ = nf;
  num_current_ = nf;
}

FourKFaceSet FourKMesh::pre_image(HalfEdgeId e) const {
  if (!is_modification(e)) throw InvalidInput("FourKMesh::pre_image: " + he_name(e) + " names no modification", e);
  FourKFaceSet s;
  s.faces[s.size++] = fbase(e);
  if (mate_[e] != kInvalid) s.faces[s.size++] = fbase(mate_[e]);
  return s;
}

FourKFaceSet FourKMesh::image(HalfEdgeId e) const {
  const FourKFaceSet pre = pre_image(e);
  const bool swap = modification_type(e) == NodeKind::kSwap;
  FourKFaceSet s;
  for (FaceId f : pre) {
    s.faces[s.size++] = child(f, 0);
    if (!swap) s.faces[s.size++] = child(f, 1);
  }
  return s;
}

NodeKind FourKMesh::modification_type(HalfEdgeId e) const {
  if (!is_modification(e))
    throw InvalidInput("FourKMesh::modification_type: " + he_name(e) + " names no modification", e);
  const HalfEdgeId m = mate_[e];
  if (child(fbase(e), 1) == kInvalid && m != kInvalid && child(fbase(m), 1) == kInvalid) return NodeKind::kSwap;
  return NodeKind::kSplit;
}

void FourKMesh::check_current_half_edge(HalfEdgeId h, const char* op) const {
  if (h >= point_.size())
    throw InvalidInput(std::string("FourKMesh::") + op + ": half-edge " + std::to_string(h) + " out of range", h);
  if (!is_current(fbase(h)))
    throw InvalidInput(std::string("FourKMesh::") + op + ": " + he_name(h) + " belongs to a face that was already refined", h);
}

void FourKMesh::check_error(HalfEdgeId h, float error, const char* op) const {
  if (!(error >= 0.0f) || !std::isfinite(error))
    throw InvalidInput(std::string("FourKMesh::") + op + ": error of the modification at " + he_name(h) +
                           " must be finite and >= 0",
                       h);
}

void FourKMesh::check_capacity(std::size_t new_faces, HalfEdgeId h, const char* op) const {
  if (num_faces() + new_faces > kMaxFaces)
    throw InvalidInput(std::string("FourKMesh::") + op + ": at " + he_name(h) + ": more than 2^32 half-edges", h);
}

void FourKMesh::reserve(std::size_t faces, std::size_t vertices) {
  positions_.reserve(vertices);
  point_.reserve(3 * faces);
  mate_.reserve(3 * faces);
  parent_.reserve(faces);
  children_.reserve(2 * faces);
  error_.reserve(faces);
}

void FourKMesh::rotate(FaceId f, int k) {
  if (k == 0) return;
  const std::array<VertexId, 3> p{point_[3 * f], point_[3 * f + 1], point_[3 * f + 2]};
  const std::array<HalfEdgeId, 3> m{mate_[3 * f], mate_[3 * f + 1], mate_[3 * f + 2]};
  for (int i = 0; i < 3; ++i) {
    const int j = (i + k) % 3;
    point_[3 * f + i] = p[j];
    mate_[3 * f + i] = m[j];
    if (m[j] != kInvalid) mate_[m[j]] = 3 * f + static_cast<Index>(i);
  }
}

FaceId FourKMesh::new_face(VertexId a, VertexId b, VertexId c, FaceId parent) {
  const auto f = static_cast<FaceId>(parent_.size());
  point_.insert(point_.end(), {a, b, c});
  mate_.insert(mate_.end(), {kInvalid, kInvalid, kInvalid});
  parent_.push_back(parent);
  children_.insert(children_.end(), {kInvalid, kInvalid});
  error_.push_back(0.0f);
  ++num_current_;
  return f;
}

void FourKMesh::adopt_outer(HalfEdgeId from, HalfEdgeId to) {
  const HalfEdgeId y = mate_[from];
  if (y != kInvalid) link(to, y);
}

void FourKMesh::retire(FaceId f, FaceId c0, FaceId c1, float error) {
  children_[2 * f] = c0;
  children_[2 * f + 1] = c1;
  error_[f] = error;
  mate_[3 * f + 1] = kInvalid;
  mate_[3 * f + 2] = kInvalid;
  --num_current_;
}

VertexId FourKMesh::split(HalfEdgeId h, const glm::vec3& position, float error) {
  check_current_half_edge(h, "split");
  check_error(h, error, "split");
  if (!finite(position)) throw InvalidInput("FourKMesh::split: position of the new vertex at " + he_name(h) + " is not finite", h);
  check_capacity(mate_[h] == kInvalid ? 2 : 4, h, "split");
  if (positions_.size() >= kInvalid) throw InvalidInput("FourKMesh::split: more than 2^32 vertices", h);

  const FaceId f = fbase(h);
  rotate(f, static_cast<int>(h % 3));
  const HalfEdgeId hm = mate_[3 * f];
  const FaceId g = hm == kInvalid ? kInvalid : fbase(hm);
  if (g != kInvalid) rotate(g, static_cast<int>(hm % 3));

  // f = (a, b, c), g = (b, a, d); Figure 12.
  const VertexId a = point_[3 * f], b = point_[3 * f + 1], c = point_[3 * f + 2];
  const auto m = static_cast<VertexId>(positions_.size());
  positions_.push_back(position);
  const FaceId f0 = new_face(c, a, m, f), f1 = new_face(b, c, m, f);
  adopt_outer(3 * f + 2, 3 * f0);
  adopt_outer(3 * f + 1, 3 * f1);
  link(3 * f0 + 2, 3 * f1 + 1);
  retire(f, f0, f1, error);
  if (g != kInvalid) {
    const VertexId d = point_[3 * g + 2];
    const FaceId g0 = new_face(d, b, m, g), g1 = new_face(a, d, m, g);
    adopt_outer(3 * g + 2, 3 * g0);
    adopt_outer(3 * g + 1, 3 * g1);
    link(3 * g0 + 2, 3 * g1 + 1);
    link(3 * f0 + 1, 3 * g1 + 2);
    link(3 * f1 + 2, 3 * g0 + 1);
    retire(g, g0, g1, error);
  }
  log_.push_back(3 * f);
  return m;
}

bool FourKMesh::has_edge_near(HalfEdgeId out_of_c, VertexId d) const noexcept {
  // Walk the umbrella of out_of_c's origin through mates, one way and, if it is open, the other way.
  auto touches = [&](HalfEdgeId x) { return target(x) == d || point_[prev(x)] == d; };
  HalfEdgeId x = out_of_c;
  std::size_t guard = point_.size();
  bool closed = false;
  while (guard-- > 0) {
    if (touches(x)) return true;
    const HalfEdgeId y = mate_[prev(x)];
    if (y == kInvalid) break;
    x = y;
    if (x == out_of_c) {
      closed = true;
      break;
    }
  }
  if (closed) return false;
  x = out_of_c;
  guard = point_.size();
  while (guard-- > 0) {
    const HalfEdgeId y = mate_[x];
    if (y == kInvalid) break;
    x = next(y);
    if (x == out_of_c) break;
    if (touches(x)) return true;
  }
  return false;
}

bool FourKMesh::can_swap(HalfEdgeId h) const noexcept {
  if (h >= point_.size() || !is_current(fbase(h))) return false;
  const HalfEdgeId hm = mate_[h];
  if (hm == kInvalid) return false;
  const VertexId c = point_[prev(h)], d = point_[prev(hm)];
  if (c == d) return false;
  return !has_edge_near(prev(h), d) && !has_edge_near(prev(hm), c);
}

void FourKMesh::swap(HalfEdgeId h, float error) {
  check_current_half_edge(h, "swap");
  check_error(h, error, "swap");
  if (!can_swap(h))
    throw InvalidInput("FourKMesh::swap: " + he_name(h) +
                           " cannot be swapped (border edge, or the opposite corners are equal or already joined)",
                       h);
  check_capacity(2, h, "swap");
  const FaceId f = fbase(h);
  rotate(f, static_cast<int>(h % 3));
  const HalfEdgeId hm = mate_[3 * f];
  const FaceId g = fbase(hm);
  rotate(g, static_cast<int>(hm % 3));

  // f = (a, b, c), g = (b, a, d) become (d, c, a) and (c, d, b); Figure 13.
  const VertexId a = point_[3 * f], b = point_[3 * f + 1], c = point_[3 * f + 2], d = point_[3 * g + 2];
  const FaceId fs = new_face(d, c, a, f), gs = new_face(c, d, b, g);
  adopt_outer(3 * f + 2, 3 * fs + 1);
  adopt_outer(3 * g + 1, 3 * fs + 2);
  adopt_outer(3 * g + 2, 3 * gs + 1);
  adopt_outer(3 * f + 1, 3 * gs + 2);
  link(3 * fs, 3 * gs);
  retire(f, fs, kInvalid, error);
  retire(g, gs, kInvalid, error);
  log_.push_back(3 * f);
}

void FourKMesh::set_error(HalfEdgeId e, float error) {
  if (!is_modification(e)) throw InvalidInput("FourKMesh::set_error: " + he_name(e) + " names no modification", e);
  check_error(e, error, "set_error");
  for (FaceId f : pre_image(e)) error_[f] = error;
}

std::vector<FaceId> FourKMesh::current_faces() const {
  std::vector<FaceId> out;
  out.reserve(num_current_);
  for (FaceId f = 0; f < num_faces(); ++f)
    if (is_current(f)) out.push_back(f);
  return out;
}

TriMesh FourKMesh::current_mesh(std::vector<FaceId>* face_ids) const {
  TriMesh m;
  m.positions = positions_;
  m.indices.reserve(3 * num_current_);
  if (face_ids) {
    face_ids->clear();
    face_ids->reserve(num_current_);
  }
  for (FaceId f = 0; f < num_faces(); ++f)
    if (is_current(f)) {
      m.indices.insert(m.indices.end(), {point_[3 * f], point_[3 * f + 1], point_[3 * f + 2]});
      if (face_ids) face_ids->push_back(f);
    }
  return m;
}

Mt FourKMesh::to_mt(const MtBuilder::Options& options, FourKMtMap* map) const {
  MtBuilder builder;
  for (const glm::vec3& p : positions_) builder.add_vertex(p);
  for (FaceId f = 0; f < num_faces(); ++f) builder.add_face(point_[3 * f], point_[3 * f + 1], point_[3 * f + 2]);
  std::vector<FaceId> base(num_base_faces_);
  for (FaceId f = 0; f < num_base_faces_; ++f) base[f] = f;
  builder.set_base(base);
  for (HalfEdgeId e : log_) {
    const FourKFaceSet pre = pre_image(e);
    const FourKFaceSet img = image(e);
    float err = 0.0f;
    for (FaceId f : pre) err = std::max(err, error_[f]);
    builder.add_node(modification_type(e), pre.span(), img.span(), err);
  }
  std::vector<NodeId> node_new_to_old;
  std::vector<FaceId> face_new_to_old;
  Mt mt = std::move(builder).build(options, map ? &node_new_to_old : nullptr, map ? &face_new_to_old : nullptr);
  if (map) {
    map->node_edge.resize(node_new_to_old.size());
    for (std::size_t n = 0; n < node_new_to_old.size(); ++n)
      map->node_edge[n] = node_new_to_old[n] == 0 ? kInvalid : log_[node_new_to_old[n] - 1];
    map->face = std::move(face_new_to_old);
  }
  return mt;
}

void FourKMesh::validate() const {
  auto fail = [](const std::string& why, std::uint64_t element) {
    throw InvalidInput("FourKMesh::validate: " + why, element);
  };
  const std::size_t nf = num_faces(), nv = num_vertices();
  // 1. Sizes and values.
  if (point_.size() != 3 * nf || mate_.size() != 3 * nf || children_.size() != 2 * nf || error_.size() != nf)
    fail("array sizes disagree", 0);
  if (num_base_faces_ == 0 || num_base_faces_ > nf) fail("no base face", 0);
  for (VertexId v = 0; v < nv; ++v)
    if (!finite(positions_[v])) fail("vertex " + std::to_string(v) + " is not finite", v);
  std::size_t current = 0;
  for (FaceId f = 0; f < nf; ++f) {
    const auto [a, b, c] = face(f);
    if (a >= nv || b >= nv || c >= nv) fail("face " + std::to_string(f) + " has a corner out of range", f);
    if (a == b || b == c || a == c) fail("face " + std::to_string(f) + " repeats a corner", f);
    if (!(error_[f] >= 0.0f) || !std::isfinite(error_[f])) fail("face " + std::to_string(f) + " has a bad error", f);
    // 2. Parents.
    if (f < num_base_faces_) {
      if (parent_[f] != kInvalid) fail("base face " + std::to_string(f) + " has a parent", f);
    } else if (parent_[f] == kInvalid || parent_[f] >= f) {
      fail("face " + std::to_string(f) + " has no parent created before it", f);
    }
    // 3. Children.
    const FaceId c0 = child(f, 0), c1 = child(f, 1);
    if (c0 == kInvalid) {
      if (c1 != kInvalid) fail("face " + std::to_string(f) + " has children[1] but no children[0]", f);
      if (error_[f] != 0.0f) fail("current face " + std::to_string(f) + " has a modification error", f);
      ++current;
      continue;
    }
    for (FaceId ch : {c0, c1})
      if (ch != kInvalid && (ch >= nf || ch <= f || parent_[ch] != f))
        fail("face " + std::to_string(f) + " and its child " + std::to_string(ch) + " disagree", f);
    if (mate_[3 * f + 1] != kInvalid || mate_[3 * f + 2] != kInvalid)
      fail("removed face " + std::to_string(f) + " keeps a mate on edge[1] or edge[2]", f);
  }
  if (current != num_current_) fail("current face count is stale", 0);

  // 5 and 6. Modifications: partners, kinds, children's corners.
  for (FaceId f = 0; f < nf; ++f) {
    if (is_current(f)) continue;
    const HalfEdgeId e = 3 * f, em = mate_[e];
    const bool is_split = child(f, 1) != kInvalid;
    const auto [a, b, c] = face(f);
    if (em == kInvalid) {
      if (!is_split) fail("face " + std::to_string(f) + " is swapped without a partner", f);
    } else {
      if (em >= point_.size() || em % 3 != 0 || mate_[em] != e)
        fail("removed face " + std::to_string(f) + ": edge[0] is not mated to its partner's edge[0]", f);
      const FaceId g = fbase(em);
      if (is_current(g)) fail("removed face " + std::to_string(f) + " has a current partner", f);
      if ((child(g, 1) != kInvalid) != is_split)
        fail("faces " + std::to_string(f) + " and " + std::to_string(g) + " of one modification have different kinds", f);
      if (point_[em] != b || point_[em + 1] != a)
        fail("face " + std::to_string(f) + " and its partner do not share edge[0] reversed", f);
      if (g < f) continue;  // checked from the partner
    }
    // Up to a cyclic shift: a child still current may have been shifted for a modification of another edge.
    auto expect = [&](FaceId ch, std::array<VertexId, 3> want, FaceId owner) {
      const std::array<VertexId, 3> got = face(ch);
      for (int r = 0; r < 3; ++r)
        if (got[0] == want[r] && got[1] == want[(r + 1) % 3] && got[2] == want[(r + 2) % 3]) return;
      fail("child " + std::to_string(ch) + " of face " + std::to_string(owner) + " does not have the corners of its modification", owner);
    };
    if (is_split) {
      VertexId m = kInvalid;
      for (VertexId v : face(child(f, 0)))
        if (v != a && v != b && v != c) m = v;
      if (m == kInvalid) fail("split of face " + std::to_string(f) + " has no new vertex", f);
      expect(child(f, 0), {c, a, m}, f);
      expect(child(f, 1), {b, c, m}, f);
      if (em != kInvalid) {
        const FaceId g = fbase(em);
        const VertexId d = point_[3 * g + 2];
        if (m == d) fail("split of face " + std::to_string(f) + " reuses a corner as new vertex", f);
        expect(child(g, 0), {d, b, m}, g);
        expect(child(g, 1), {a, d, m}, g);
      }
    } else {
      const FaceId g = fbase(em);
      const VertexId d = point_[3 * g + 2];
      expect(child(f, 0), {d, c, a}, f);
      expect(child(g, 0), {c, d, b}, g);
    }
  }
  {
    std::vector<std::uint8_t> logged(nf, 0);
    for (HalfEdgeId e : log_) {
      if (!is_modification(e)) fail("logged " + he_name(e) + " names no modification", e);
      for (FaceId f : pre_image(e)) {
        if (logged[f]) fail("face " + std::to_string(f) + " is removed by two logged modifications", f);
        logged[f] = 1;
      }
    }
    for (FaceId f = 0; f < nf; ++f)
      if (!is_current(f) && !logged[f]) fail("removed face " + std::to_string(f) + " is in no logged modification", f);
  }

  // 4. The current mesh.
  std::vector<std::uint64_t> keys;
  keys.reserve(3 * num_current_);
  for (FaceId f = 0; f < nf; ++f)
    if (is_current(f))
      for (int k = 0; k < 3; ++k) keys.push_back(directed_edge_key(point_[3 * f + k], point_[3 * f + (k + 1) % 3]));
  std::sort(keys.begin(), keys.end());
  for (std::size_t i = 1; i < keys.size(); ++i)
    if (keys[i] == keys[i - 1])
      fail("directed edge (" + std::to_string(keys[i] >> 32) + ", " + std::to_string(keys[i] & 0xffffffffu) +
               ") is used twice in the current mesh",
           0);
  for (FaceId f = 0; f < nf; ++f) {
    if (!is_current(f)) continue;
    for (int k = 0; k < 3; ++k) {
      const HalfEdgeId h = 3 * f + static_cast<Index>(k), m = mate_[h];
      if (m == kInvalid) {
        if (std::binary_search(keys.begin(), keys.end(), directed_edge_key(target(h), point(h))))
          fail(he_name(h) + " has no mate but its reversed edge is in the current mesh", h);
        continue;
      }
      if (m >= point_.size() || mate_[m] != h || !is_current(fbase(m)) || point(m) != target(h) || target(m) != point(h))
        fail(he_name(h) + " and its mate disagree", h);
    }
  }
}

std::size_t FourKMesh::memory_bytes() const noexcept {
  auto bytes = [](const auto& v) { return v.size() * sizeof(v[0]); };
  return bytes(positions_) + bytes(point_) + bytes(mate_) + bytes(parent_) + bytes(children_) + bytes(error_) +
         bytes(log_);
}

}  // namespace varmesh
