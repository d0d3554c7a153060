// The building pipelines on tiny meshes. Input: byte 0 chooses the analysis options, byte 1 the subdivision
// scheme and steps, byte 2 seeds the random operations; the rest is an OBJ file of at most 64 vertices and
// 128 triangles (larger inputs are skipped, so that a run stays in milliseconds). When read_mesh_data
// accepts it: analyze_mesh; build_vertex_hierarchy with the chosen options, the hierarchy's validate(),
// mesh_after_collapses and random SrMesh vsplit/ecol operations with the mesh's validate() after them; the
// 4-k side: FourKMesh with a few random edge splits and its MT, pair_triangles and poly_from_triangles
// and one or two subdivision steps. Only the documented errors for bad input (IoError, InvalidInput) may
// escape; anything else, a broken invariant or a sanitizer report is a finding.
#include <cstddef>
#include <cstdint>
#include <exception>
#include <optional>
#include <string_view>
#include <vector>

#include "fourk/fourk_mesh.hpp"
#include "fourk/poly_mesh.hpp"
#include "fourk/subdiv.hpp"
#include "fuzz_support.hpp"
#include "multitri/mesh_io.hpp"
#include "multitri/mesh_report.hpp"
#include "multitri/mt_front.hpp"
#include "multitri/query.hpp"
#include "pm/qem_analysis.hpp"
#include "pm/sr_mesh.hpp"

namespace {

using namespace varmesh;

// xorshift32: reproducible choices from the input's seed byte.
struct Random {
  std::uint32_t s;
  std::uint32_t next() {
    s ^= s << 13;
    s ^= s >> 17;
    s ^= s << 5;
    return s;
  }
  std::size_t below(std::size_t n) { return n == 0 ? 0 : next() % n; }
};

QemOptions analysis_options(std::uint8_t b, const TriMesh& mesh) {
  QemOptions o;
  switch (b & 7) {
    case 0: break;
    case 1: o.threads = 2; o.min_part_faces = 4; break;
    case 2: o.lt_finish = 0.0; o.target_faces = mesh.num_faces() / 4 + 1; break;
    case 3: o.cost = CollapseCost::kLindstromTurk; break;
    case 4: o.use_colors = true; o.target_vertices = mesh.num_vertices() / 3 + 1; break;
    case 5: o.non_manifold = NonManifoldPolicy::kLock; break;
    case 6: o.target_faces = mesh.num_faces() / 8 + 1; break;  // with the Lindstrom-Turk finish
    case 7: o.max_error = 1e-3; o.preserve_volume = false; break;
  }
  if (b & 8) o.non_manifold = NonManifoldPolicy::kLock;
  if (b & 16) o.max_depth = 3 + (b >> 5);
  return o;
}

void pm_side(const TriMesh& mesh, std::uint8_t options, Random& rnd) {
  VertexHierarchy h;
  // InvalidInput is documented for a mesh with no non-degenerate face (and for bad options, none here).
  if (!fuzz::run_expecting_only_documented_errors([&] { h = build_vertex_hierarchy(mesh, analysis_options(options, mesh)); }))
    return;
  fuzz::run_expecting_no_error([&] {
    h.validate();
    mesh_after_collapses(h, rnd.below(h.num_collapses() + 1)).validate();
    const RefinementScheme schemes[] = {RefinementScheme::kKimLee, RefinementScheme::kHoppe97,
                                        RefinementScheme::kXiaVarshney};
    SrMesh sr(h, schemes[rnd.below(3)]);
    for (int op = 0; op < 24; ++op) {
      const Index v = static_cast<Index>(rnd.below(h.num_nodes()));
      if (sr.is_active(v) && !h.is_leaf(v)) {
        sr.vsplit(v);
      } else if (sr.is_active(v) && h.parent(v) != kInvalid && sr.is_active(h.sibling(v))) {
        sr.ecol(h.parent(v));
      }
      sr.validate();
    }
    sr.to_mesh().validate();
    sr.refine_all();
    sr.validate();
    VARMESH_FUZZ_CHECK(sr.num_faces() == h.num_faces());
  });
}

void fourk_side(const TriMesh& mesh, std::uint8_t subdiv, Random& rnd) {
  std::optional<FourKMesh> fk;
  // The constructor refuses the topology problems its header lists, with InvalidInput.
  if (fuzz::run_expecting_only_documented_errors([&] { fk.emplace(mesh); })) {
    // can_swap() looks for the new edge in the umbrellas reached through mates only, so at a non-manifold
    // vertex (which FourKMesh accepts) it can miss one and the swap duplicates an edge: documented, and
    // validate() reports it. Swaps are tried on meshes without such vertices.
    const bool manifold = analyze_mesh(mesh).non_manifold_vertices == 0;
    bool swapped = false;
    fuzz::run_expecting_no_error([&] {
      fk->validate();
      for (int op = 0; op < 6; ++op) {
        const std::vector<FaceId> current = fk->current_faces();
        const FaceId f = current[rnd.below(current.size())];
        const HalfEdgeId e = FourKMesh::edge(f, static_cast<int>(rnd.below(3)));
        const glm::vec3 a = fk->positions()[fk->point(e)], b = fk->positions()[fk->point(FourKMesh::next(e))];
        if (rnd.next() & 1) {
          fk->split(e, 0.5f * a + 0.5f * b, static_cast<float>(op));
        } else if (manifold && fk->can_swap(e)) {
          fk->swap(e, static_cast<float>(op));
          swapped = true;
        }
        fk->validate();
      }
      fk->current_mesh().validate();
    });
    // to_mt() refuses, with InvalidInput, a hierarchy in which a swap recreated an earlier face.
    std::optional<Mt> mt;
    const bool built = fuzz::run_expecting_only_documented_errors([&] { mt.emplace(fk->to_mt()); });
    if (!built && !swapped) fuzz::finding("to_mt refused a FourKMesh made by splits alone");
    if (built) {
      fuzz::run_expecting_no_error([&] {
        mt->validate();
        MtFront front(*mt);
        extract(front, Query{});
        front.validate();
        front.to_mesh().validate();
      });
    }
  }
  const SubdivScheme schemes[] = {SubdivScheme::kLinear, SubdivScheme::kCatmullClark, SubdivScheme::kFourEight,
                                  SubdivScheme::kCatmullClark};
  const SubdivScheme scheme = schemes[subdiv & 3];
  const int steps = 1 + ((subdiv >> 2) & 1);
  for (int variant = 0; variant < 2; ++variant) {
    std::optional<PolyMesh> poly;
    // pair_triangles refuses FourKMesh's topology problems; PolyMesh::validate() also non-manifold
    // vertices, which a TriMesh may have.
    if (!fuzz::run_expecting_only_documented_errors([&] {
          poly.emplace(variant == 0 ? pair_triangles(mesh) : poly_from_triangles(mesh));
          poly->validate();
        }))
      continue;
    fuzz::run_expecting_no_error([&] {
      const SubdivMesh s = subdivide(*poly, scheme, steps);
      s.to_tri_mesh().validate();
    });
    // The subdivision MT may refuse a base face whose every fan repeats an edge (InvalidInput).
    if (subdiv & 8) {
      std::optional<Mt> mt;
      if (fuzz::run_expecting_only_documented_errors([&] { mt.emplace(build_subdivision_mt(*poly, scheme, steps)); }))
        fuzz::run_expecting_no_error([&] { mt->validate(); });
    }
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 3 || size > 4096) return 0;
  const std::string_view file(reinterpret_cast<const char*>(data + 3), size - 3);
  TriMesh mesh;
  try {
    mesh = read_mesh_data("fuzz.obj", file);
  } catch (const IoError&) {
    return 0;
  }
  if (mesh.num_vertices() > 64 || mesh.num_faces() > 128) return 0;
  Random rnd{0x9e3779b9u ^ data[2]};
  // The reader's meshes pass TriMesh::validate(), and analyze_mesh throws only when that fails.
  fuzz::run_expecting_no_error([&] { analyze_mesh(mesh); });
  fuzz::run_expecting_only_documented_errors([&] { pm_side(mesh, data[0], rnd); });
  fourk_side(mesh, data[1], rnd);
  return 0;
}
