#pragma once
/// Selective refinement to a predicate, and the inputs of the Kim-Lee 2001 experiments (section 5, Table 2):
/// regular meshes from images and height fields, and Sobel feature points.
///
/// refine_to_predicate() drives an SrMesh under any of its three schemes with one loop, so the schemes
/// differ only in their dependency rules: a node "needs refinement" when a caller's predicate says so (for
/// feature points: a feature leaf lies below it; for a view: its bounding sphere meets the frustum and its
/// normal cone is not entirely back-facing); the loop splits every active node that needs it, coarsest
/// first, until no active node needs it. What a scheme adds on top (forced splits and collapses, the
/// Kim-Lee pre-splits of degenerate cases) is what SrStats counts.
///
/// The predicate should be monotone (a node that needs refinement has ancestors that need it too; true for
/// flags propagated up the tree and for view criteria on the nested bounds of build_vertex_hierarchy); then
/// the Kim-Lee result is the smallest active set in which no active node needs refinement, up to the
/// pre-splits of section 4.4.
#include <cstddef>
#include <cstdint>
#include <functional>
#include <span>
#include <vector>

#include "multitri/heightfield.hpp"
#include "multitri/image.hpp"
#include "multitri/tri_mesh.hpp"
#include "pm/sr_mesh.hpp"
#include "pm/vertex_hierarchy.hpp"

namespace varmesh {

/// What refine_to_predicate did. `stats` is the change of SrMesh::stats() over the call.
struct SelectiveRefineResult {
  std::size_t requested_vsplits = 0;  ///< vsplit() calls made by the loop that succeeded
  std::size_t refused_vsplits = 0;    ///< vsplit() calls that returned false (Xia-Varshney dependency cycles)
  std::size_t rounds = 0;             ///< full scans of the active set
  std::size_t unsatisfied = 0;        ///< active nodes still needing refinement at the end (0 when complete)
  bool complete() const noexcept { return unsatisfied == 0; }
  SrStats stats;
};

/// Splits active non-leaf nodes v with needs_refinement(v) until none is left, under mesh.scheme(). Each
/// round scans the active set and splits what needs it from the coarsest node down (largest id first, as
/// a progressive mesh would), pushing split nodes' children; rounds repeat while a scheme's forced
/// operations leave needy active nodes behind (a forced Xia-Varshney collapse can), at most `max_rounds`
/// times. Requires needs_refinement to be callable on any node id. Time O(rounds * nodes + operations * k)
/// for k-vertex 1-rings. Throws InvalidInput when max_rounds is 0 or needs_refinement is empty; propagates
/// what SrMesh throws and what needs_refinement throws.
SelectiveRefineResult refine_to_predicate(SrMesh& mesh, const std::function<bool(Index)>& needs_refinement,
                                          std::size_t max_rounds = 64);

/// Per-node flags: node v is flagged when a flagged leaf lies below it (or v is that leaf). `leaf_flags`
/// has one entry per leaf. O(nodes). Throws InvalidInput when leaf_flags has the wrong size.
std::vector<std::uint8_t> flag_ancestors(const VertexHierarchy& h, std::span<const std::uint8_t> leaf_flags);

/// Per-leaf flags for input vertices: leaf l is flagged when h.leaf_to_input()[l] is listed (every copy of a
/// split non-manifold vertex is flagged). Throws InvalidInput naming an input vertex that no leaf comes from.
std::vector<std::uint8_t> leaves_of_inputs(const VertexHierarchy& h, std::span<const Index> input_vertices);

/// Box-filtered image: each output pixel averages a factor x factor block (a partial block at the right or
/// bottom edge averages what it has). Keeps `channels`; the result is 8-bit. Throws InvalidInput on an
/// empty or inconsistent image or factor < 1.
Image downsample_image(const Image& image, std::size_t factor);

/// Box-filtered height field (averages of factor x factor blocks, partial blocks at the far edges); the
/// spacings are multiplied by `factor`. Throws InvalidInput (validate()) or when factor < 1.
HeightField downsample_heightfield(const HeightField& field, std::size_t factor);

/// Luma of pixel (x, y) in [0, 1]: gray as is, RGB(A) by Rec. 601 weights.
float image_luma(const Image& image, std::size_t x, std::size_t y) noexcept;

/// Sobel gradient magnitude of the luma, row-major, border pixels replicated. Magnitude of a unit step
/// is 4. Throws InvalidInput on an empty or inconsistent image.
std::vector<float> sobel_magnitude(const Image& image);

/// Feature pixels (indices y * width + x, increasing) in the top `fraction` of the non-zero magnitudes: the
/// threshold is the ceil(fraction * pixels)-th largest magnitude and every pixel at or above it (and above
/// zero) is kept, so ties may add a few. Throws InvalidInput when fraction is not in (0, 1] or a magnitude
/// is NaN (naming its index).
std::vector<Index> top_fraction_features(std::span<const float> magnitude, double fraction);

/// A regular mesh with one vertex per pixel (Kim-Lee section 5, the "2D regular mesh"): pixel (x, y) at
/// (x, height - 1 - y, 0) so the picture is upright seen from +z with +y up; vertex colour = pixel colour
/// (gray gives gray RGB; alpha is ignored); two counter-clockwise triangles per 2x2 block with alternating
/// diagonals. Vertex index = y * width + x. Throws InvalidInput when a side is below 2.
TriMesh image_grid_mesh(const Image& image);

/// The same grid for a height field: sample (x, y) at field.to_world(x, y); vertex index = y * width + x.
/// Throws InvalidInput (validate()) or when a side is below 2.
TriMesh heightfield_grid_mesh(const HeightField& field);

/// A generated gray test image for the feature experiment when no image file is at hand: a diagonal
/// gradient with discs, a ring and a square of other grey levels (sharp edges for the Sobel mask).
/// Deterministic. Throws InvalidInput when size < 8.
Image make_feature_test_image(std::size_t size);

}  // namespace varmesh
