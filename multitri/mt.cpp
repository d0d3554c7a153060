#include "multitri/mt.hpp"

#include <algorithm>
#include <array>
#include <limits>
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


// Oriented boundary of a face set: directed edges whose reverse is not in the set (counted with
// multiplicity), plus the undirected interior edges. Both sorted.
// `directed` is scratch space (kept by the caller so that a node costs no allocation).
void boundary_and_interior(const std::vector<Index>& corners, std::span<const FaceId> faces,
                           std::vector<std::uint64_t>& boundary, std::vector<std::uint64_t>& interior,
                           std::vector<std::uint64_t>& directed) {
  directed.clear();
  for (FaceId f : faces)
    for (int k = 0; k < 3; ++k)
      directed.push_back(directed_edge_key(corners[3 * f + k], corners[3 * f + (k + 1) % 3]));
  std::sort(directed.begin(), directed.end());
  boundary.clear();
  interior.clear();
  for (std::uint64_t e : directed) {
    const auto a = static_cast<VertexId>(e >> 32), b = static_cast<VertexId>(e & 0xffffffffu);
    // A node's faces are usually few: then a linear scan beats a binary search.
    const std::uint64_t rev = directed_edge_key(b, a);
    const bool has_reverse = directed.size() <= 32 ? std::find(directed.begin(), directed.end(), rev) != directed.end()
                                                   : std::binary_search(directed.begin(), directed.end(), rev);
    if (has_reverse) {
      if (a < b) interior.push_back(e);
    } else {
      boundary.push_back(e);
    }
  }
}

glm::vec3 face_normal(const glm::vec3& a, const glm::vec3& b, const glm::vec3& c) {
  // In double: in float the cross product of edges past ~1.8e19 overflows and the normal became NaN.
  const glm::dvec3 n = glm::cross(glm::dvec3(b) - glm::dvec3(a), glm::dvec3(c) - glm::dvec3(a));
  const double len = glm::length(n);
  return len > 0.0 && std::isfinite(len) ? glm::vec3(n / len) : glm::vec3(0.0f);
}

// Cone of the given unit normals around their mean direction (full cone if they span a hemisphere).
NormalCone normal_cone(const std::vector<glm::vec3>& normals) {
  glm::vec3 mean(0.0f);
  for (const auto& n : normals) mean += n;
  const float len = glm::length(mean);
  if (!(len >= 1e-12f) || !std::isfinite(len)) return {};  // also NaN: a full cone, never a NaN axis
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
  if (kind != NodeKind::kSplit && kind != NodeKind::kSwap && kind != NodeKind::kGeneric)
    throw InvalidInput("MtBuilder: node " + std::to_string(id) + " has an unknown kind " +
                           std::to_string(static_cast<int>(kind)),
                       id);
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
  // Non-redundancy: one vertex triple, one face. With vertex ids of at most kCornerBits bits the sorted
  // triple packs into one word and a sort of words finds any repeat; the slower sort of (triple, face)
  // then runs only to name the faces (the same pair as without the shortcut), or for wider ids.
  // The words are bucketed by the smallest vertex first (a counting sort), so only each vertex's few
  // faces are sorted.
  bool may_repeat = true;
  if (positions_.size() <= (std::size_t{1} << Mt::kCornerBits)) {
    std::vector<Index> bucket(positions_.size() + 1, 0);
    auto sorted_triple = [&](FaceId f) {
      Index a = corners_[3 * f], b = corners_[3 * f + 1], c = corners_[3 * f + 2];
      if (a > b) std::swap(a, b);
      if (b > c) std::swap(b, c);
      if (a > b) std::swap(a, b);
      return std::array<Index, 3>{a, b, c};
    };
    for (FaceId f = 0; f < num_faces; ++f) ++bucket[sorted_triple(f)[0] + 1];
    for (std::size_t v = 0; v + 1 < bucket.size(); ++v) bucket[v + 1] += bucket[v];
    std::vector<std::uint64_t> rest(num_faces);
    {
      std::vector<Index> fill(bucket.begin(), bucket.end() - 1);
      for (FaceId f = 0; f < num_faces; ++f) {
        const auto t = sorted_triple(f);
        rest[fill[t[0]]++] = (std::uint64_t{t[1]} << Mt::kCornerBits) | t[2];
      }
    }
    may_repeat = false;
    for (std::size_t v = 0; v + 1 < bucket.size() && !may_repeat; ++v) {
      const auto first = rest.begin() + bucket[v], last = rest.begin() + bucket[v + 1];
      std::sort(first, last);
      may_repeat = std::adjacent_find(first, last) != last;
    }
  }
  if (may_repeat) {
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
    // The directed edges of all faces by first vertex (a counting sort), built on first use: structures
    // without borders never need them.
    std::vector<Index> out_begin, out_end;
    auto on_border = [&](std::uint64_t e) {
      if (out_begin.empty()) {
        out_begin.assign(positions_.size() + 1, 0);
        for (Index v : corners_) ++out_begin[v + 1];
        for (std::size_t v = 0; v + 1 < out_begin.size(); ++v) out_begin[v + 1] += out_begin[v];
        out_end.resize(corners_.size());
        std::vector<Index> fill(out_begin.begin(), out_begin.end() - 1);
        for (std::size_t f = 0; f < num_faces; ++f)
          for (std::size_t k = 0; k < 3; ++k) out_end[fill[corners_[3 * f + k]]++] = corners_[3 * f + (k + 1) % 3];
      }
      // e = a -> b is on the border when no face has b -> a.
      const auto a = static_cast<Index>(e >> 32), b = static_cast<Index>(e & 0xffffffffu);
      const auto first = out_end.begin() + out_begin[b], last = out_end.begin() + out_begin[b + 1];
      return std::find(first, last, a) == last;
    };
    std::vector<std::uint64_t> b0, i0, b1, i1, diff, scratch;
    // A face set that uses a directed edge twice is no oriented surface patch (after the call, `scratch`
    // holds its directed edges sorted).
    auto no_repeated_edge = [&](NodeId n, const char* which) {
      const auto it = std::adjacent_find(scratch.begin(), scratch.end());
      if (it != scratch.end())
        fail(std::string(which) + " uses the directed edge " + std::to_string(*it >> 32) + "-" +
                 std::to_string(*it & 0xFFFFFFFFu) + " twice",
             n);
    };
    scratch.clear();
    for (FaceId f : created(0))
      for (int k = 0; k < 3; ++k) scratch.push_back(directed_edge_key(corners_[3 * f + k], corners_[3 * f + (k + 1) % 3]));
    std::sort(scratch.begin(), scratch.end());
    no_repeated_edge(0, "the base mesh");
    std::vector<Index> pre_corners;
    for (NodeId n = 1; n < num_nodes; ++n) {
      boundary_and_interior(corners_, removed(n), b0, i0, scratch);
      no_repeated_edge(n, "its pre-image");
      boundary_and_interior(corners_, created(n), b1, i1, scratch);
      no_repeated_edge(n, "its image");
      diff.clear();
      std::set_symmetric_difference(b0.begin(), b0.end(), b1.begin(), b1.end(), std::back_inserter(diff));
      for (std::uint64_t e : diff)
        if (!on_border(e)) fail("its image does not have the same oriented boundary as its pre-image", n);
      // On the border, each edge u -> v the node takes away must come back subdivided: a path of new edges
      // u -> ... -> v, every new edge on one such path. (Any other change of border edges passed before,
      // and two nodes could then create the same directed edge in one front.)
      if (!diff.empty()) {
        std::vector<std::uint64_t> gone, added;
        std::set_difference(b0.begin(), b0.end(), b1.begin(), b1.end(), std::back_inserter(gone));
        std::set_difference(b1.begin(), b1.end(), b0.begin(), b0.end(), std::back_inserter(added));
        std::vector<std::uint8_t> used(added.size(), 0);
        auto next_from = [&](Index u) -> std::size_t {  // the unused added edge leaving u, if exactly one
          auto it = std::lower_bound(added.begin(), added.end(), std::uint64_t{u} << 32);
          std::size_t found = added.size(), count = 0;
          for (; it != added.end() && (*it >> 32) == u; ++it)
            if (!used[static_cast<std::size_t>(it - added.begin())]) found = static_cast<std::size_t>(it - added.begin()), ++count;
          return count == 1 ? found : added.size();
        };
        // The path's inner vertices are new: none is a corner of the pre-image (a path through one would
        // fold the border onto the patch).
        pre_corners.clear();
        for (FaceId f : removed(n)) pre_corners.insert(pre_corners.end(), &corners_[3 * f], &corners_[3 * f] + 3);
        std::sort(pre_corners.begin(), pre_corners.end());
        for (std::uint64_t e : gone) {
          const Index u = static_cast<Index>(e >> 32), v = static_cast<Index>(e & 0xFFFFFFFFu);
          Index at = u;
          for (std::size_t steps = 0; at != v; ++steps) {
            const std::size_t k = next_from(at);
            if (k == added.size() || steps > added.size() ||
                (at != u && std::binary_search(pre_corners.begin(), pre_corners.end(), at)))
              fail("changes the structure's border other than by subdividing edge " + std::to_string(u) + "-" +
                       std::to_string(v),
                   n);
            used[k] = 1;
            at = static_cast<Index>(added[k] & 0xFFFFFFFFu);
          }
        }
        for (std::size_t k = 0; k < added.size(); ++k)
          if (!used[k])
            fail("adds border edge " + std::to_string(added[k] >> 32) + "-" + std::to_string(added[k] & 0xFFFFFFFFu) +
                     " that subdivides no edge it takes away",
                 n);
      }
      for (std::uint64_t e : i0)
        if (std::binary_search(i1.begin(), i1.end(), e))
          fail("keeps an interior edge of its pre-image (not a minimal modification)", n);
    }
    // Every vertex has one origin: the base mesh, or the one node whose image brings it in (a corner of the
    // image that is no corner of the pre-image). An image corner from elsewhere - a vertex of the base or of
    // another node's image - passes every boundary test, yet puts a directed edge twice into some front
    // (found by re-sealing edited .vrm files).
    std::vector<NodeId> origin(positions_.size(), kInvalid);
    for (FaceId f : created(0))
      for (int k = 0; k < 3; ++k) origin[corners_[3 * f + k]] = 0;
    std::vector<Index> own_pre;
    for (NodeId n = 1; n < num_nodes; ++n) {
      own_pre.clear();
      for (FaceId f : removed(n)) own_pre.insert(own_pre.end(), &corners_[3 * f], &corners_[3 * f] + 3);
      const bool few = own_pre.size() <= 12;  // splits and swaps: a linear search beats the sort
      if (!few) std::sort(own_pre.begin(), own_pre.end());
      for (FaceId f : created(n))
        for (int k = 0; k < 3; ++k) {
          const Index v = corners_[3 * f + k];
          if (origin[v] == n) continue;
          if (few ? std::find(own_pre.begin(), own_pre.end(), v) != own_pre.end()
                  : std::binary_search(own_pre.begin(), own_pre.end(), v))
            continue;
          if (origin[v] != kInvalid)
            fail("brings in vertex " + std::to_string(v) + ", which " +
                     (origin[v] == 0 ? std::string("the base mesh uses") : "node " + std::to_string(origin[v]) + " brings in"),
                 n);
          origin[v] = n;
        }
    }
  }

  // Node graph (parent = creator of a removed face) and a parents-first order (Kahn).
  // Both as flat arrays (offsets + items): parents of n sorted and distinct, children of p in increasing
  // node order.
  std::vector<Index> parent_begin(num_nodes + 1, 0);
  std::vector<NodeId> parent_items;
  parent_items.reserve(removed_items_.size());
  for (NodeId n = 1; n < num_nodes; ++n) {
    const auto at = static_cast<std::ptrdiff_t>(parent_items.size());
    for (FaceId f : removed(n)) parent_items.push_back(creator[f]);
    std::sort(parent_items.begin() + at, parent_items.end());
    parent_items.erase(std::unique(parent_items.begin() + at, parent_items.end()), parent_items.end());
    parent_begin[n + 1] = static_cast<Index>(parent_items.size());
  }
  std::vector<Index> child_begin(num_nodes + 1, 0);
  for (NodeId p : parent_items) ++child_begin[p + 1];
  for (std::size_t n = 0; n < num_nodes; ++n) child_begin[n + 1] += child_begin[n];
  std::vector<NodeId> child_items(parent_items.size());
  {
    std::vector<Index> fill(child_begin.begin(), child_begin.end() - 1);
    for (NodeId n = 1; n < num_nodes; ++n)
      for (Index k = parent_begin[n]; k < parent_begin[n + 1]; ++k) child_items[fill[parent_items[k]]++] = n;
  }
  std::vector<Index> missing(num_nodes);
  for (NodeId n = 0; n < num_nodes; ++n) missing[n] = parent_begin[n + 1] - parent_begin[n];
  std::vector<NodeId> order;
  order.reserve(num_nodes);
  for (NodeId n = 0; n < num_nodes; ++n)
    if (missing[n] == 0) order.push_back(n);
  if (order.size() != 1 || order[0] != 0) {
    const NodeId bad = order[0] == 0 ? order[1] : order[0];
    fail("has no parent but is not the source", bad);
  }
  for (std::size_t i = 0; i < order.size(); ++i)
    for (Index k = child_begin[order[i]]; k < child_begin[order[i] + 1]; ++k)
      if (--missing[child_items[k]] == 0) order.push_back(child_items[k]);
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
  const bool wide = mt.positions_.size() > (std::size_t{1} << Mt::kCornerBits);
  if (wide)
    mt.wide_corners_.resize(3 * num_faces);
  else
    mt.packed_corners_.resize(num_faces);
  mt.destroyer_.resize(num_faces);
  for (FaceId nf = 0; nf < num_faces; ++nf) {
    const FaceId of = old_face_of_new[nf];
    if (wide) {
      for (int k = 0; k < 3; ++k) mt.wide_corners_[3 * nf + k] = corners_[3 * of + k];
    } else {
      mt.packed_corners_[nf] = std::uint64_t{corners_[3 * of]} | (std::uint64_t{corners_[3 * of + 1]} << Mt::kCornerBits) |
                               (std::uint64_t{corners_[3 * of + 2]} << (2 * Mt::kCornerBits));
    }
    mt.destroyer_[nf] = destroyer[of] == kInvalid ? kInvalid : new_of_old[destroyer[of]];
  }
  corners_ = {};
  mt.creator_hint_.resize(((num_faces - 1) >> Mt::kHintShift) + 1);
  for (NodeId n = 0; n < num_nodes; ++n)
    for (FaceId f = mt.image_begin_[n]; f < mt.image_begin_[n + 1]; ++f)
      if ((f & ((FaceId{1} << Mt::kHintShift) - 1)) == 0) mt.creator_hint_[f >> Mt::kHintShift] = n;
  mt.pre_offsets_.assign(1, 0);
  mt.pre_items_.reserve(removed_items_.size());
  for (NodeId i = 0; i < num_nodes; ++i) {
    const auto at = mt.pre_items_.size();
    for (FaceId f : removed(order[i])) mt.pre_items_.push_back(new_face_of_old[f]);
    std::sort(mt.pre_items_.begin() + static_cast<std::ptrdiff_t>(at), mt.pre_items_.end());
    mt.pre_offsets_.push_back(static_cast<Index>(mt.pre_items_.size()));
  }

  // Bounds: the region a node changes is its pre-image (= its image, as a point set).
  std::vector<ElementBound> bounds(num_nodes);
  std::vector<glm::vec3> pts, normals;
  for (NodeId n = 0; n < num_nodes; ++n) {
    pts.clear();
    normals.clear();
    auto add_face = [&](FaceId f) {
      const auto v = mt.face(f);
      for (int k = 0; k < 3; ++k) pts.push_back(mt.positions_[v[k]]);
      normals.push_back(face_normal(mt.positions_[v[0]], mt.positions_[v[1]], mt.positions_[v[2]]));
    };
    for (FaceId f : mt.pre_image(n)) add_face(f);
    for (FaceId f = mt.image_begin(n); f < mt.image_end(n); ++f) add_face(f);
    const Sphere s = bounding_sphere(pts.data(), pts.size());
    ElementBound& b = bounds[n];
    b.center = s.center;
    b.radius = s.radius;
    b.error = n == 0 ? 0.0f : errors_[order[n] - 1];
    b.cone = normal_cone(normals);
  }
  if (options.saturate) {
    for (NodeId n = static_cast<NodeId>(num_nodes); n-- > 1;) {
      ElementBound& b = bounds[n];
      for (NodeId c : mt.children(n)) {
        const ElementBound& cb = bounds[c];
        const Sphere s = enclose(Sphere{b.center, b.radius}, Sphere{cb.center, cb.radius});
        b.center = s.center;
        b.radius = s.radius;
        b.error = std::max(b.error, cb.error);
        b.cone = enclose(b.cone, cb.cone);
      }
    }
    // The source is never refined or coarsened; give it a bound enclosing everything.
    Sphere all{bounds[0].center, bounds[0].radius};
    float err = 0.0f;
    for (NodeId c : mt.children(0)) {
      all = enclose(all, Sphere{bounds[c].center, bounds[c].radius});
      err = std::max(err, bounds[c].error);
    }
    bounds[0].center = all.center;
    bounds[0].radius = all.radius;
    bounds[0].error = err;
  }
  mt.pack_bounds(bounds, options.saturate);

  if (node_new_to_old) *node_new_to_old = std::move(order);
  if (face_new_to_old) *face_new_to_old = std::move(old_face_of_new);
  return mt;
}

namespace {

constexpr double kConeUnit = 1.5707963267948966 / 254.0;  // radians per half-angle code

std::uint32_t encode_octahedral(const glm::vec3& axis) {
  const glm::dvec3 a = glm::normalize(glm::dvec3(axis));
  const double l1 = std::abs(a.x) + std::abs(a.y) + std::abs(a.z);
  double x = a.x / l1, y = a.y / l1;
  if (a.z < 0.0) {
    const double ox = x;
    x = std::copysign(1.0 - std::abs(y), ox);
    y = std::copysign(1.0 - std::abs(ox), y);
  }
  const auto q = [](double t) { return static_cast<long>(std::floor((t + 1.0) * 0.5 * 4095.0)); };
  // Of the four grid points around (x, y), keep the one whose decoded axis is closest.
  std::uint32_t best = 0;
  double best_dot = -2.0;
  for (long du = 0; du < 2; ++du)
    for (long dv = 0; dv < 2; ++dv) {
      const auto u = static_cast<std::uint32_t>(std::clamp(q(x) + du, 0L, 4095L));
      const auto v = static_cast<std::uint32_t>(std::clamp(q(y) + dv, 0L, 4095L));
      const std::uint32_t code = u | (v << 12);
      const double d = glm::dot(glm::dvec3(Mt::decode_octahedral(code)), a);
      if (d > best_dot) {
        best_dot = d;
        best = code;
      }
    }
  return best;
}

double angle_between(const glm::vec3& a, const glm::vec3& b) {
  return std::acos(std::clamp(glm::dot(glm::dvec3(a), glm::dvec3(b)), -1.0, 1.0));
}

// Half-angle code for at least `angle` radians (with slack for float decoding), or the full-cone code.
std::uint32_t cone_angle_code(double angle) {
  const double code = std::ceil((angle + 1e-5) / kConeUnit);
  if (!(code <= 254.0)) return Mt::kFullConeCode;  // NaN too: the cast below would be undefined
  return static_cast<std::uint32_t>(std::max(code, 0.0));
}

}  // namespace

std::uint16_t Mt::Frame::encode_radius(float need) const {
  // Smallest code whose decoded radius covers `need` with a relative slack: nested spheres must stay
  // nested after the float rounding of distances computed from them (see enclose()).
  const float target = need * (1.0f + 2e-6f);
  if (!(radius(65535) >= target))
    throw InvalidInput("MtBuilder: bounding sphere of radius " + std::to_string(need) +
                           " too large to pack (the coordinates span more than float can measure?)",
                       0);
  std::uint32_t first = 0, last = 65535;
  while (first < last) {
    const std::uint32_t mid = (first + last) / 2;
    if (radius(static_cast<std::uint16_t>(mid)) >= target)
      last = mid;
    else
      first = mid + 1;
  }
  return static_cast<std::uint16_t>(first);
}

void Mt::pack_bounds(const std::vector<ElementBound>& bounds, bool nest) {
  Box3 box;
  for (const glm::vec3& p : positions_) box.add(p);
  for (const ElementBound& b : bounds) box.add(b.center);
  frame_.lo = box.lo;
  // In double: hi - lo overflows float for coordinates near +-3.4e38 (inf steps decode centres as NaN).
  frame_.step = glm::vec3((glm::dvec3(box.hi) - glm::dvec3(box.lo)) / 65535.0);
  // Lengths in double here and below: |d|^2 of float vectors overflows past coordinates of ~1.8e19.
  const auto dist = [](const glm::vec3& a, const glm::vec3& b) {
    return static_cast<float>(glm::length(glm::dvec3(a) - glm::dvec3(b)));
  };
  const float diag = dist(box.hi, box.lo);
  // Radius unit: the diagonal, or the largest radius when that is larger. Radii never exceed the diagonal
  // on models of ordinary size, but enclose() adds an absolute 1e-12 of float slack, which dwarfs a model
  // measured in units of 1e-20 and left its spheres "too large to pack".
  float largest = 0.0f;
  for (const ElementBound& b : bounds)
    if (std::isfinite(b.radius)) largest = std::max(largest, b.radius);
  frame_.unit = std::min(std::max(diag, largest), std::numeric_limits<float>::max());
  if (!(frame_.unit > 0.0f)) frame_.unit = 1.0f;
  bounds_.resize(bounds.size());
  for (std::size_t n = 0; n < bounds.size(); ++n) {
    const ElementBound& b = bounds[n];
    PackedBound& p = bounds_[n];
    for (int k = 0; k < 3; ++k) {
      const double t = frame_.step[k] > 0.0f ? (double(b.center[k]) - frame_.lo[k]) / frame_.step[k] : 0.0;
      p.c[k] = static_cast<std::uint16_t>(std::clamp(std::lround(t), 0L, 65535L));
    }
    p.r = frame_.encode_radius(b.radius + dist(frame_.center(p.c), b.center));
    p.error = b.error;
    const bool finite_cone = std::isfinite(b.cone.axis.x) && std::isfinite(b.cone.axis.y) && std::isfinite(b.cone.axis.z) &&
                             std::isfinite(b.cone.cos_half_angle) && glm::dot(b.cone.axis, b.cone.axis) > 0.0f;
    if (b.cone.is_full() || !finite_cone) {
      p.cone = kFullConeCode << 24;
    } else {
      const std::uint32_t axis = encode_octahedral(b.cone.axis);
      const double half = std::acos(std::clamp(double(b.cone.cos_half_angle), -1.0, 1.0));
      p.cone = axis | (cone_angle_code(half + angle_between(decode_octahedral(axis), b.cone.axis)) << 24);
    }
  }
  if (!nest) return;
  // Quantization moved centres and rounded radii and angles up, each node on its own: grow parents
  // (children first) until every decoded child bound lies in its decoded parent's again.
  for (NodeId n = static_cast<NodeId>(bounds_.size()); n-- > 0;) {
    PackedBound& p = bounds_[n];
    for (NodeId c : children(n)) {
      const PackedBound& q = bounds_[c];
      p.error = std::max(p.error, q.error);
      const float need = dist(frame_.center(p.c), frame_.center(q.c)) + frame_.radius(q.r);
      if (frame_.radius(p.r) < need * (1.0f + 2e-6f)) p.r = frame_.encode_radius(need);
      const std::uint32_t pa = p.cone >> 24, qa = q.cone >> 24;
      if (pa == kFullConeCode) continue;
      if (qa == kFullConeCode) {
        p.cone = kFullConeCode << 24;
        continue;
      }
      const double need_angle = angle_between(decode_octahedral(p.cone), decode_octahedral(q.cone)) + qa * kConeUnit;
      if (need_angle > pa * kConeUnit) p.cone = (p.cone & 0xffffffu) | (cone_angle_code(need_angle) << 24);
    }
  }
}

void Mt::validate() const {
  const std::size_t nn = num_nodes(), nf = num_faces();
  auto fail = [](const std::string& why, std::uint64_t e) { throw InvalidInput("Mt::validate: " + why, e); };
  if (nn == 0 || kind_[0] != NodeKind::kSource) fail("node 0 is not the source", 0);
  if (image_begin_.size() != nn + 1 || image_begin_[0] != 0 || image_begin_[nn] != nf)
    fail("image ranges do not cover the faces", 0);
  if (pre_offsets_.size() != nn + 1 || bounds_.size() != nn) fail("per-node arrays have the wrong size", 0);
  if (creator_hint_.size() != ((nf + (FaceId{1} << kHintShift) - 1) >> kHintShift)) fail("creator hints have the wrong size", 0);
  for (NodeId n = 0; n < nn; ++n) {
    if (image_begin_[n] >= image_begin_[n + 1]) fail("node " + std::to_string(n) + " has an empty image", n);
    for (FaceId f = image_begin_[n]; f < image_begin_[n + 1]; ++f) {
      if ((f >> kHintShift) << kHintShift == f && creator_hint_[f >> kHintShift] != n)
        fail("creator hint of face " + std::to_string(f) + " disagrees with the image ranges", f);
      if (creator(f) != n) fail("face " + std::to_string(f) + " creator disagrees with its image range", f);
    }
    if (n > 0 && pre_image(n).empty()) fail("node " + std::to_string(n) + " has an empty pre-image", n);
    FaceId prev = 0;
    bool first = true;
    for (FaceId f : pre_image(n)) {
      if (f >= nf || destroyer_[f] != n) fail("node " + std::to_string(n) + " pre-image face disagrees", n);
      if (!first && f <= prev) fail("node " + std::to_string(n) + " pre-image is not sorted", n);
      if (creator(f) >= n) fail("node " + std::to_string(n) + " precedes the creator of its pre-image", n);
      prev = f;
      first = false;
    }
    for (NodeId p : parents(n))
      if (p >= n) fail("node " + std::to_string(n) + " has a parent numbered after it", n);
    for (NodeId c : children(n))
      if (c <= n) fail("node " + std::to_string(n) + " has a child numbered before it", n);
  }
  for (FaceId f = 0; f < nf; ++f) {
    for (VertexId v : face(f))
      if (v >= positions_.size()) fail("face " + std::to_string(f) + " vertex out of range", f);
    if (destroyer_[f] != kInvalid && destroyer_[f] >= nn) fail("face " + std::to_string(f) + " destroyer out of range", f);
  }
}

std::vector<Mt::MemoryItem> Mt::memory_breakdown() const {
  auto bytes = [](const auto& v) { return v.size() * sizeof(v[0]); };
  return {
      {"positions (12 B / vertex)", bytes(positions_)},
      {wide_corners_.empty() ? "corners (8 B / face, 21-bit packed)" : "corners (12 B / face)",
       bytes(packed_corners_) + bytes(wide_corners_)},
      {"destroyer (4 B / face)", bytes(destroyer_)},
      {"creator hints (4 B / 16 faces)", bytes(creator_hint_)},
      {"bounds (16 B / node, packed)", bytes(bounds_)},
      {"pre-image offsets + items", bytes(pre_offsets_) + bytes(pre_items_)},
      {"image_begin + kind", bytes(image_begin_) + bytes(kind_)},
      {"Mt object", sizeof(Mt)},
  };
}

std::size_t Mt::memory_bytes() const noexcept {
  auto bytes = [](const auto& v) { return v.size() * sizeof(v[0]); };
  return sizeof(Mt) + bytes(positions_) + bytes(packed_corners_) + bytes(wide_corners_) + bytes(destroyer_) +
         bytes(creator_hint_) + bytes(kind_) + bytes(pre_offsets_) + bytes(pre_items_) + bytes(image_begin_) +
         bytes(bounds_);
}

}  // namespace varmesh
