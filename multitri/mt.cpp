#include "multitri/mt.hpp"

#include <algorithm>
#include <iterator>
#include <cmath>
#include <numeric>
#include <string>
#include <tuple>

#include "multitri/errors.hpp"

namespace varmesh {

const char* to_string(NodeKind kind) noexcept {
  switch (kind) {
    case NodeKind::kSource: return "source";
    case NodeKind::kSplit: return "split";
    case NodeKind::kSwap: return "swap";
    case NodeKind::kGeneric: return "generic";
  }
  return "?";
}

namespace {

using Edge = std::pair<VertexId, VertexId>;

std::uint64_t edge_key(VertexId a, VertexId b) { return (std::uint64_t(a) << 32) | b; }

// Oriented boundary of a face set: directed edges whose reverse is not in the set (counted with
// multiplicity), plus the undirected interior edges. Both sorted.
void boundary_and_interior(const std::vector<Index>& corners, std::span<const FaceId> faces,
                           std::vector<std::uint64_t>& boundary, std::vector<std::uint64_t>& interior) {
  std::vector<std::uint64_t> directed;
  directed.reserve(faces.size() * 3);
  for (FaceId f : faces)
    for (int k = 0; k < 3; ++k)
      directed.push_back(edge_key(corners[3 * f + k], corners[3 * f + (k + 1) % 3]));
  std::sort(directed.begin(), directed.end());
  boundary.clear();
  interior.clear();
  for (std::uint64_t e : directed) {
    const auto a = static_cast<VertexId>(e >> 32), b = static_cast<VertexId>(e & 0xffffffffu);
    if (std::binary_search(directed.begin(), directed.end(), edge_key(b, a))) {
      if (a < b) interior.push_back(e);
    } else {
      boundary.push_back(e);
    }
  }
}

glm::vec3 face_normal(const std::vector<glm::vec3>& p, const std::vector<Index>& c, FaceId f) {
  const glm::vec3 n = glm::cross(p[c[3 * f + 1]] - p[c[3 * f]], p[c[3 * f + 2]] - p[c[3 * f]]);
  const float len = glm::length(n);
  return len > 0.0f ? n / len : glm::vec3(0.0f);
}

// Cone of the given unit normals around their mean direction (full cone if they span a hemisphere).
NormalCone normal_cone(const std::vector<glm::vec3>& normals) {
  glm::vec3 mean(0.0f);
  for (const auto& n : normals) mean += n;
  const float len = glm::length(mean);
  if (len < 1e-12f) return {};
  mean /= len;
  float c = 1.0f;
  for (const auto& n : normals)
    if (glm::dot(n, n) > 0.0f) c = std::min(c, glm::dot(n, mean));
  if (c <= 0.0f) return {};
  return {mean, c - 1e-6f};
}

}  // namespace

VertexId MtBuilder::add_vertex(const glm::vec3& p) {
  if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
    throw InvalidInput("MtBuilder: vertex position is not finite", positions_.size());
  positions_.push_back(p);
  return static_cast<VertexId>(positions_.size() - 1);
}

FaceId MtBuilder::add_face(VertexId a, VertexId b, VertexId c) {
  const auto n = positions_.size();
  if (a >= n || b >= n || c >= n)
    throw InvalidInput("MtBuilder: face refers to a vertex that was not added", corners_.size() / 3);
  corners_.insert(corners_.end(), {a, b, c});
  return static_cast<FaceId>(corners_.size() / 3 - 1);
}

void MtBuilder::set_base(std::span<const FaceId> faces) {
  if (has_base_) throw InvalidInput("MtBuilder: set_base called twice");
  base_.assign(faces.begin(), faces.end());
  has_base_ = true;
}

NodeId MtBuilder::add_node(NodeKind kind, std::span<const FaceId> removed, std::span<const FaceId> created,
                           float error) {
  const NodeId id = static_cast<NodeId>(kinds_.size() + 1);  // builder node 0 is the source
  if (kind == NodeKind::kSource) throw InvalidInput("MtBuilder: only set_base creates the source", id);
  if (!(error >= 0.0f) || !std::isfinite(error)) throw InvalidInput("MtBuilder: node error must be finite and >= 0", id);
  kinds_.push_back(kind);
  errors_.push_back(error);
  removed_items_.insert(removed_items_.end(), removed.begin(), removed.end());
  removed_offsets_.push_back(static_cast<Index>(removed_items_.size()));
  created_items_.insert(created_items_.end(), created.begin(), created.end());
  created_offsets_.push_back(static_cast<Index>(created_items_.size()));
  return id;
}

Mt MtBuilder::build(const Options& options, std::vector<NodeId>* node_new_to_old,
                    std::vector<FaceId>* face_new_to_old) && {
  if (!has_base_ || base_.empty()) throw InvalidInput("MtBuilder: the base mesh (source image) is empty", 0);
  const std::size_t num_nodes = kinds_.size() + 1;
  const std::size_t num_faces = corners_.size() / 3;
  auto removed = [&](NodeId n) -> std::span<const FaceId> {
    if (n == 0) return {};
    return {removed_items_.data() + removed_offsets_[n - 1], removed_offsets_[n] - removed_offsets_[n - 1]};
  };
  auto created = [&](NodeId n) -> std::span<const FaceId> {
    if (n == 0) return base_;
    return {created_items_.data() + created_offsets_[n - 1], created_offsets_[n] - created_offsets_[n - 1]};
  };
  auto fail = [](const std::string& why, NodeId n) {
    throw InvalidInput("MtBuilder: node " + std::to_string(n) + ": " + why, n);
  };

  // Arity per kind, face ids in range, degenerate faces.
  for (NodeId n = 1; n < num_nodes; ++n) {
    const auto r = removed(n), c = created(n);
    if (r.empty()) fail("empty pre-image (only the source creates faces from nothing)", n);
    if (c.empty()) fail("empty image", n);
    const NodeKind k = kinds_[n - 1];
    if (k == NodeKind::kSplit && !((r.size() == 2 && c.size() == 4) || (r.size() == 1 && c.size() == 2)))
      fail("a split must replace 2 faces by 4 (or 1 by 2 on a border), not " + std::to_string(r.size()) + " by " +
               std::to_string(c.size()),
           n);
    if (k == NodeKind::kSwap && !(r.size() == 2 && c.size() == 2))
      fail("a swap must replace 2 faces by 2", n);
  }
  std::vector<NodeId> creator(num_faces, kInvalid), destroyer(num_faces, kInvalid);
  for (NodeId n = 0; n < num_nodes; ++n) {
    for (FaceId f : created(n)) {
      if (f >= num_faces) fail("creates face " + std::to_string(f) + " which was never added", n);
      if (creator[f] != kInvalid)
        fail("creates face " + std::to_string(f) + " already created by node " + std::to_string(creator[f]), n);
      creator[f] = n;
    }
    for (FaceId f : removed(n)) {
      if (f >= num_faces) fail("removes face " + std::to_string(f) + " which was never added", n);
      if (destroyer[f] != kInvalid)
        fail("removes face " + std::to_string(f) + " already removed by node " + std::to_string(destroyer[f]), n);
      destroyer[f] = n;
    }
  }
  for (FaceId f = 0; f < num_faces; ++f) {
    if (creator[f] == kInvalid) throw InvalidInput("MtBuilder: face " + std::to_string(f) + " is created by no node", f);
    if (creator[f] == destroyer[f]) fail("removes face " + std::to_string(f) + " that it creates", creator[f]);
    const Index a = corners_[3 * f], b = corners_[3 * f + 1], c = corners_[3 * f + 2];
    if (a == b || b == c || a == c) fail("creates degenerate face " + std::to_string(f), creator[f]);
  }
  // Non-redundancy: one vertex triple, one face.
  {
    std::vector<std::tuple<Index, Index, Index, FaceId>> keys(num_faces);
    for (FaceId f = 0; f < num_faces; ++f) {
      std::array<Index, 3> v{corners_[3 * f], corners_[3 * f + 1], corners_[3 * f + 2]};
      std::sort(v.begin(), v.end());
      keys[f] = {v[0], v[1], v[2], f};
    }
    std::sort(keys.begin(), keys.end());
    for (std::size_t i = 1; i < keys.size(); ++i)
      if (std::get<0>(keys[i]) == std::get<0>(keys[i - 1]) && std::get<1>(keys[i]) == std::get<1>(keys[i - 1]) &&
          std::get<2>(keys[i]) == std::get<2>(keys[i - 1]))
        fail("creates face " + std::to_string(std::get<3>(keys[i])) + " with the same vertices as face " +
                 std::to_string(std::get<3>(keys[i - 1])) + " (redundant)",
             creator[std::get<3>(keys[i])]);
  }
  // Minimal compatibility.
  if (options.check_geometry) {
    // Edges on the border of the whole structure (no face uses them in reverse) may be subdivided: that is
    // how a border split (1 face -> 2) works, and no other face can see the difference.
    std::vector<std::uint64_t> all_edges;
    all_edges.reserve(corners_.size());
    for (std::size_t f = 0; f < num_faces; ++f)
      for (int k = 0; k < 3; ++k) all_edges.push_back(edge_key(corners_[3 * f + k], corners_[3 * f + (k + 1) % 3]));
    std::sort(all_edges.begin(), all_edges.end());
    auto on_border = [&](std::uint64_t e) {
      const std::uint64_t rev = (e << 32) | (e >> 32);
      return !std::binary_search(all_edges.begin(), all_edges.end(), rev);
    };
    std::vector<std::uint64_t> b0, i0, b1, i1, diff;
    for (NodeId n = 1; n < num_nodes; ++n) {
      boundary_and_interior(corners_, removed(n), b0, i0);
      boundary_and_interior(corners_, created(n), b1, i1);
      diff.clear();
      std::set_symmetric_difference(b0.begin(), b0.end(), b1.begin(), b1.end(), std::back_inserter(diff));
      for (std::uint64_t e : diff)
        if (!on_border(e)) fail("its image does not have the same oriented boundary as its pre-image", n);
      for (std::uint64_t e : i0)
        if (std::binary_search(i1.begin(), i1.end(), e))
          fail("keeps an interior edge of its pre-image (not a minimal modification)", n);
    }
  }

  // Node graph (parent = creator of a removed face) and a parents-first order (Kahn).
  std::vector<std::vector<NodeId>> parents(num_nodes), children(num_nodes);
  for (NodeId n = 1; n < num_nodes; ++n) {
    for (FaceId f : removed(n)) parents[n].push_back(creator[f]);
    std::sort(parents[n].begin(), parents[n].end());
    parents[n].erase(std::unique(parents[n].begin(), parents[n].end()), parents[n].end());
    for (NodeId p : parents[n]) children[p].push_back(n);
  }
  std::vector<Index> missing(num_nodes);
  for (NodeId n = 0; n < num_nodes; ++n) missing[n] = static_cast<Index>(parents[n].size());
  std::vector<NodeId> order;
  order.reserve(num_nodes);
  for (NodeId n = 0; n < num_nodes; ++n)
    if (missing[n] == 0) order.push_back(n);
  if (order.size() != 1 || order[0] != 0) {
    const NodeId bad = order[0] == 0 ? order[1] : order[0];
    fail("has no parent but is not the source", bad);
  }
  for (std::size_t i = 0; i < order.size(); ++i)
    for (NodeId c : children[order[i]])
      if (--missing[c] == 0) order.push_back(c);
  if (order.size() != num_nodes) {
    for (NodeId n = 0; n < num_nodes; ++n)
      if (missing[n] != 0) fail("lies on a cycle of the dependency graph", n);
  }
  std::vector<NodeId> new_of_old(num_nodes);
  for (NodeId i = 0; i < num_nodes; ++i) new_of_old[order[i]] = i;

  Mt mt;
  mt.positions_ = std::move(positions_);
  mt.kind_.resize(num_nodes);
  mt.image_begin_.resize(num_nodes + 1);
  std::vector<FaceId> new_face_of_old(num_faces, kInvalid);
  std::vector<FaceId> old_face_of_new;
  old_face_of_new.reserve(num_faces);
  for (NodeId i = 0; i < num_nodes; ++i) {
    const NodeId old = order[i];
    mt.kind_[i] = old == 0 ? NodeKind::kSource : kinds_[old - 1];
    mt.image_begin_[i] = static_cast<FaceId>(old_face_of_new.size());
    for (FaceId f : created(old)) {
      new_face_of_old[f] = static_cast<FaceId>(old_face_of_new.size());
      old_face_of_new.push_back(f);
    }
  }
  mt.image_begin_[num_nodes] = static_cast<FaceId>(old_face_of_new.size());
  mt.corners_.resize(3 * num_faces);
  mt.creator_.resize(num_faces);
  mt.destroyer_.resize(num_faces);
  for (FaceId nf = 0; nf < num_faces; ++nf) {
    const FaceId of = old_face_of_new[nf];
    for (int k = 0; k < 3; ++k) mt.corners_[3 * nf + k] = corners_[3 * of + k];
    mt.creator_[nf] = new_of_old[creator[of]];
    mt.destroyer_[nf] = destroyer[of] == kInvalid ? kInvalid : new_of_old[destroyer[of]];
  }
  mt.pre_offsets_.assign(1, 0);
  mt.parent_offsets_.assign(1, 0);
  mt.child_offsets_.assign(1, 0);
  for (NodeId i = 0; i < num_nodes; ++i) {
    const NodeId old = order[i];
    for (FaceId f : removed(old)) mt.pre_items_.push_back(new_face_of_old[f]);
    mt.pre_offsets_.push_back(static_cast<Index>(mt.pre_items_.size()));
    std::vector<NodeId> ps, cs;
    for (NodeId p : parents[old]) ps.push_back(new_of_old[p]);
    for (NodeId c : children[old]) cs.push_back(new_of_old[c]);
    std::sort(ps.begin(), ps.end());
    std::sort(cs.begin(), cs.end());
    mt.parent_items_.insert(mt.parent_items_.end(), ps.begin(), ps.end());
    mt.parent_offsets_.push_back(static_cast<Index>(mt.parent_items_.size()));
    mt.child_items_.insert(mt.child_items_.end(), cs.begin(), cs.end());
    mt.child_offsets_.push_back(static_cast<Index>(mt.child_items_.size()));
  }

  // Bounds: the region a node changes is its pre-image (= its image, as a point set).
  mt.bounds_.resize(num_nodes);
  std::vector<glm::vec3> pts, normals;
  for (NodeId n = 0; n < num_nodes; ++n) {
    pts.clear();
    normals.clear();
    auto add_face = [&](FaceId f) {
      for (int k = 0; k < 3; ++k) pts.push_back(mt.positions_[mt.corners_[3 * f + k]]);
      normals.push_back(face_normal(mt.positions_, mt.corners_, f));
    };
    for (FaceId f : mt.pre_image(n)) add_face(f);
    for (FaceId f = mt.image_begin(n); f < mt.image_end(n); ++f) add_face(f);
    const Sphere s = bounding_sphere(pts.data(), pts.size());
    ElementBound& b = mt.bounds_[n];
    b.center = s.center;
    b.radius = s.radius;
    b.error = n == 0 ? 0.0f : errors_[order[n] - 1];
    b.cone = normal_cone(normals);
  }
  if (options.saturate) {
    for (NodeId n = static_cast<NodeId>(num_nodes); n-- > 1;) {
      ElementBound& b = mt.bounds_[n];
      for (NodeId c : mt.children(n)) {
        const ElementBound& cb = mt.bounds_[c];
        const Sphere s = enclose(Sphere{b.center, b.radius}, Sphere{cb.center, cb.radius});
        b.center = s.center;
        b.radius = s.radius;
        b.error = std::max(b.error, cb.error);
        b.cone = enclose(b.cone, cb.cone);
      }
    }
    // The source is never refined or coarsened; give it a bound enclosing everything.
    Sphere all{mt.bounds_[0].center, mt.bounds_[0].radius};
    float err = 0.0f;
    for (NodeId c : mt.children(0)) {
      all = enclose(all, Sphere{mt.bounds_[c].center, mt.bounds_[c].radius});
      err = std::max(err, mt.bounds_[c].error);
    }
    mt.bounds_[0].center = all.center;
    mt.bounds_[0].radius = all.radius;
    mt.bounds_[0].error = err;
  }

  if (node_new_to_old) *node_new_to_old = std::move(order);
  if (face_new_to_old) *face_new_to_old = std::move(old_face_of_new);
  return mt;
}

void Mt::validate() const {
  const std::size_t nn = num_nodes(), nf = num_faces();
  auto fail = [](const std::string& why, std::uint64_t e) { throw InvalidInput("Mt::validate: " + why, e); };
  if (nn == 0 || kind_[0] != NodeKind::kSource) fail("node 0 is not the source", 0);
  if (image_begin_.size() != nn + 1 || image_begin_[nn] != nf) fail("image ranges do not cover the faces", 0);
  for (NodeId n = 0; n < nn; ++n) {
    if (image_begin_[n] > image_begin_[n + 1]) fail("image range decreasing at node " + std::to_string(n), n);
    for (FaceId f = image_begin_[n]; f < image_begin_[n + 1]; ++f)
      if (creator_[f] != n) fail("face " + std::to_string(f) + " creator disagrees with its image range", f);
    if (n > 0 && pre_image(n).empty()) fail("node " + std::to_string(n) + " has an empty pre-image", n);
    for (FaceId f : pre_image(n)) {
      if (f >= nf || destroyer_[f] != n) fail("node " + std::to_string(n) + " pre-image face disagrees", n);
      if (creator_[f] >= n) fail("node " + std::to_string(n) + " precedes the creator of its pre-image", n);
    }
    for (NodeId p : parents(n))
      if (p >= n) fail("node " + std::to_string(n) + " has a parent numbered after it", n);
    for (NodeId c : children(n))
      if (c <= n) fail("node " + std::to_string(n) + " has a child numbered before it", n);
  }
  for (FaceId f = 0; f < nf; ++f) {
    for (int k = 0; k < 3; ++k)
      if (corners_[3 * f + k] >= positions_.size()) fail("face " + std::to_string(f) + " vertex out of range", f);
    if (destroyer_[f] != kInvalid && destroyer_[f] >= nn) fail("face " + std::to_string(f) + " destroyer out of range", f);
  }
}

std::size_t Mt::memory_bytes() const noexcept {
  auto bytes = [](const auto& v) { return v.size() * sizeof(v[0]); };
  return bytes(positions_) + bytes(corners_) + bytes(creator_) + bytes(destroyer_) + bytes(kind_) +
         bytes(pre_offsets_) + bytes(pre_items_) + bytes(image_begin_) + bytes(parent_offsets_) +
         bytes(parent_items_) + bytes(child_offsets_) + bytes(child_items_) + bytes(bounds_);
}

}  // namespace varmesh
