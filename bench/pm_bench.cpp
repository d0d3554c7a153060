// Progressive-mesh benchmark for BENCHMARKS.md (issue 3, section 5), in one run:
//  1. analysis: QEM to 1% of the faces (bunny, full dragon) with varmesh, meshoptimizer's meshopt_simplify
//     and OpenMesh's Decimater + ModQuadric; time, and one distance metric for all three (RMS and max
//     distance from every original vertex to the nearest triangle of the result, found with a BVH, over the
//     bounding-box diagonal);
//  2. synthesis: SrMesh::refine_all (base -> full) and coarsen_all (full -> base) on the bunny's and the full
//     dragon's hierarchies down to their smallest base meshes, nanoseconds per operation, against the same
//     sweeps of the OpenMesh VDPM loop on the same hierarchy (depth-limited where VDPM's 32-bit ids need it);
//  3. a 200-frame camera orbit around the bunny at about 17k faces: per-frame update() against extract()
//     from scratch, update() with QueryCoherence, and OpenMesh's VDPM (Tools/VDPM + the refinement loop of
//     its VDPMSynthesizer app) driven over the SAME hierarchy with the SAME criterion; then update() with
//     and without coherence for a camera five times slower;
//  4. bytes: VertexHierarchy::memory_bytes() and the SrMesh arrays per original face.
// Times are medians of repeated runs in this process.
//
// usage: varmesh_pm_bench [--data DIR] [--reps N] [--only analysis|synthesis|frames] [--quick]
//   DIR defaults to /work/shared/data/meshes (or $VARMESH_DATA/meshes); --quick skips the dragon. Times are
//   reported as CPU time of the process (clock_gettime CLOCK_PROCESS_CPUTIME_ID: all threads, which matters
//   for the 2-thread analysis row only) and as wall time.
#include <algorithm>
#include <array>
#include <bit>
#include <chrono>

#include "bench_timing.hpp"
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <numeric>
#include <span>
#include <stdexcept>
#include <string>
#include <vector>

#include <time.h>

#include <glm/geometric.hpp>
#include <glm/vec3.hpp>
#include <meshoptimizer.h>
#include <OpenMesh/Core/Mesh/TriMesh_ArrayKernelT.hh>
#include <OpenMesh/Tools/Decimater/DecimaterT.hh>
#include <OpenMesh/Tools/Decimater/ModQuadricT.hh>
#include <OpenMesh/Tools/VDPM/MeshTraits.hh>
#include <OpenMesh/Tools/VDPM/VFront.hh>
#include <OpenMesh/Tools/VDPM/VHierarchy.hh>
#if VARMESH_HAVE_CGAL
#include <CGAL/Simple_cartesian.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/Surface_mesh_simplification/edge_collapse.h>
#include <CGAL/Surface_mesh_simplification/Policies/Edge_collapse/LindstromTurk_cost.h>
#include <CGAL/Surface_mesh_simplification/Policies/Edge_collapse/LindstromTurk_placement.h>
#endif

#include "multitri/bounds.hpp"
#include "multitri/camera.hpp"
#include "multitri/mesh_distance.hpp"
#include "multitri/mesh_io.hpp"
#include "multitri/query.hpp"
#include "pm/qem_analysis.hpp"
#include "pm/sr_mesh.hpp"

using namespace varmesh;
using Clock = varmesh::bench::Clock;

namespace {

using bench::Lap;
using bench::Laps;
using bench::median;
using bench::seconds_since;
using bench::Stopwatch;
using bench::process_cpu_seconds;

// ---- the distance metric: every original vertex to the nearest triangle of the result ----

struct Distance {
  double rms = 0.0, max = 0.0;  // over the bounding-box diagonal of the original
};

Distance distance_to(const TriMesh& original, std::span<const glm::vec3> positions, std::span<const Index> indices) {
  TriMesh result;
  result.positions.assign(positions.begin(), positions.end());
  result.indices.assign(indices.begin(), indices.end());
  const SurfaceDistance d = vertex_to_surface_distance(original, result);
  return {d.rms / d.diagonal, d.max / d.diagonal};
}

// ---- peers: meshoptimizer and OpenMesh's decimater ----

struct SimplifyResult {
  std::vector<glm::vec3> positions;
  std::vector<Index> indices;
  Lap time;
};

SimplifyResult run_meshopt(const TriMesh& m, std::size_t target_faces) {
  SimplifyResult r;
  const Stopwatch sw;
  r.indices.resize(m.indices.size());
  // target_error 1 (100% of the extents): stop only on the face count (or when no collapse is left).
  const std::size_t n = meshopt_simplify(r.indices.data(), m.indices.data(), m.indices.size(), &m.positions[0].x,
                                         m.positions.size(), sizeof(glm::vec3), 3 * target_faces, 1.0f, 0, nullptr);
  r.indices.resize(n);
  r.time = sw.lap();
  r.positions = m.positions;  // meshopt keeps the original vertices
  return r;
}

using OmMesh = OpenMesh::TriMesh_ArrayKernelT<>;

struct OmResult {
  SimplifyResult simplified;
  Lap build;  // flat arrays -> OpenMesh halfedge mesh (included in simplified.time)
  std::size_t rejected_faces = 0;
};

OmResult run_openmesh(const TriMesh& m, std::size_t target_faces) {
  OmResult out;
  const Stopwatch sw;
  OmMesh mesh;
  std::vector<OmMesh::VertexHandle> vh(m.num_vertices());
  for (std::size_t v = 0; v < m.num_vertices(); ++v)
    vh[v] = mesh.add_vertex(OmMesh::Point(m.positions[v].x, m.positions[v].y, m.positions[v].z));
  {
    // OpenMesh prints one line per complex face to its log stream; silence it during the build.
    OpenMesh::mostream& err = omerr();
    err.disable();
    for (std::size_t f = 0; f < m.num_faces(); ++f) {
      const auto fh = mesh.add_face(vh[m.indices[3 * f]], vh[m.indices[3 * f + 1]], vh[m.indices[3 * f + 2]]);
      if (!fh.is_valid()) ++out.rejected_faces;
    }
    err.enable();
  }
  out.build = sw.lap();
  using Decimater = OpenMesh::Decimater::DecimaterT<OmMesh>;
  using ModQuadric = OpenMesh::Decimater::ModQuadricT<OmMesh>::Handle;
  {
    Decimater dec(mesh);
    ModQuadric quadric;
    dec.add(quadric);
    dec.module(quadric).unset_max_err();
    dec.initialize();
    dec.decimate_to_faces(0, target_faces);
    // Inside the decimater's scope: its destructor releases the status flags garbage_collection() reads.
    mesh.garbage_collection();
  }
  out.simplified.time = sw.lap();
  for (const auto& v : mesh.vertices()) {
    const auto& p = mesh.point(v);
    out.simplified.positions.emplace_back(p[0], p[1], p[2]);
  }
  for (const auto& f : mesh.faces())
    for (const auto& v : mesh.fv_range(f)) out.simplified.indices.push_back(static_cast<Index>(v.idx()));
  return out;
}

// ---- OpenMesh VDPM driven over a varmesh hierarchy ----
//
// OpenMesh ships only the VDPM data structures (VHierarchy, VFront, node indices); the refinement loop lives
// in its VDPMSynthesizer app. VdpmDriver re-states that loop (adaptive_refinement, qrefine, force_vsplit,
// vsplit, ecol, ecol_legal, get_active_cuts) unchanged except for two things: qrefine() asks the varmesh
// Query about the varmesh node bound (so both libraries answer the same question), and vsplit/ecol move the
// kept vertex to the node position, because varmesh records full-edge collapses where VDPM's own analyzer
// records half-edge collapses. VDPM's lchild (new vertex v0) is varmesh's vt, its rchild (kept v1) is vu:
// OpenMesh's face (v0, v1, vl) is Kim-Lee's fl = (vt, vu, vl).
using VdpmMesh = OpenMesh::TriMesh_ArrayKernelT<OpenMesh::VDPM::MeshTraits>;
using OpenMesh::VDPM::VHierarchyNodeHandle;
using OpenMesh::VDPM::VHierarchyNodeIndex;

class VdpmDriver {
 public:
  // Throws std::runtime_error when the hierarchy does not fit VDPM's 32-bit node indices.
  explicit VdpmDriver(const VertexHierarchy& h) : h_(h) {
    const std::size_t nr = h.num_roots();
    vh_.set_num_roots(static_cast<unsigned>(nr));
    const int tree_bits = vh_.tree_id_bits();
    if (h.max_depth() + 1 + tree_bits > 32)
      throw std::runtime_error("depth " + std::to_string(h.max_depth()) + " + " + std::to_string(tree_bits) +
                               " tree-id bits exceed VDPM's 32-bit node index");
    handle_of_.assign(h.num_nodes(), VHierarchyNodeHandle());
    OpenMesh::VDPM::VHierarchyNodeHandleContainer roots;
    for (std::size_t i = 0; i < nr; ++i) {
      const Index r = h.roots()[i];
      const auto vtx = mesh_.add_vertex(point(r));
      const VHierarchyNodeHandle nh = vh_.add_node();
      auto& node = vh_.node(nh);
      node.set_index(vh_.generate_node_index(static_cast<unsigned>(i), 1));
      node.set_vertex_handle(vtx);
      mesh_.data(vtx).set_vhierarchy_node_handle(nh);
      handle_of_[r] = nh;
      roots.push_back(nh);
    }
    // Children: parents have larger ids than their children, so go down from the last node.
    for (std::size_t v = h.num_nodes(); v-- > h.num_leaves();) {
      VHierarchyNodeHandle nh = handle_of_[v];
      vh_.make_children(nh);
      const Index vs = static_cast<Index>(v);
      const auto l = vh_.lchild_handle(nh), r = vh_.rchild_handle(nh);
      const auto vtx0 = mesh_.add_vertex(point(h.vt(vs)));
      vh_.node(l).set_vertex_handle(vtx0);
      vh_.node(r).set_vertex_handle(vh_.node(nh).vertex_handle());
      handle_of_[h.vt(vs)] = l;
      handle_of_[h.vu(vs)] = r;
    }
    node_of_.assign(vh_.num_nodes(), kInvalid);
    for (std::size_t v = 0; v < h.num_nodes(); ++v) node_of_[static_cast<std::size_t>(handle_of_[v].idx())] = static_cast<Index>(v);
    for (std::size_t v = h.num_leaves(); v < h.num_nodes(); ++v) {
      const CollapseRecord& rec = h.record(static_cast<Index>(v));
      auto& node = vh_.node(handle_of_[v]);
      node.set_fund_lcut(rec.vl_hat != kInvalid ? vh_.node_index(handle_of_[rec.vl_hat]) : VHierarchyNodeIndex::InvalidIndex);
      node.set_fund_rcut(rec.vr_hat != kInvalid ? vh_.node_index(handle_of_[rec.vr_hat]) : VHierarchyNodeIndex::InvalidIndex);
    }
    // Base mesh: original faces with three distinct roots, relabelled.
    std::vector<Index> top(h.num_nodes());
    for (std::size_t v = h.num_nodes(); v-- > 0;) {
      const Index p = h.parent(static_cast<Index>(v));
      top[v] = p == kInvalid ? static_cast<Index>(v) : top[p];
    }
    for (Index f : h.base_faces()) {
      const auto c = h.face(f);
      const auto fh = mesh_.add_face(vertex(top[c[0]]), vertex(top[c[1]]), vertex(top[c[2]]));
      if (!fh.is_valid()) throw std::runtime_error("VDPM base mesh: face " + std::to_string(f) + " rejected");
    }
    vfront_.init(roots, static_cast<unsigned>(h.num_collapses()));
  }

  // One frame of VDPMSynthesizerViewerWidget::adaptive_refinement with `wants` as qrefine.
  template <class Wants>
  void adapt(Wants&& wants) {
    VdpmMesh::HalfedgeHandle v0v1;
    for (vfront_.begin(); !vfront_.end();) {
      const VHierarchyNodeHandle nh = vfront_.node_handle(), parent = vh_.parent_handle(nh);
      if (!vh_.is_leaf_node(nh) && wants(node_of_[static_cast<std::size_t>(nh.idx())])) {
        force_vsplit(nh);
      } else if (!vh_.is_root_node(nh) && ecol_legal(parent, v0v1) && !wants(node_of_[static_cast<std::size_t>(parent.idx())])) {
        ecol(parent, v0v1);
      } else {
        vfront_.next();
      }
    }
    mesh_.garbage_collection(false, true, true);
  }

  std::size_t num_faces() const { return mesh_.n_faces(); }
  std::size_t num_active() { return static_cast<std::size_t>(vfront_.size()); }
  std::size_t splits = 0, collapses = 0;

 private:
  VdpmMesh::Point point(Index v) const {
    const glm::vec3& p = h_.position(v);
    return {p.x, p.y, p.z};
  }
  VdpmMesh::VertexHandle vertex(Index v) { return vh_.vertex_handle(handle_of_[v]); }

  void force_vsplit(VHierarchyNodeHandle nh) {
    VdpmMesh::VertexHandle vl, vr;
    get_active_cuts(nh, vl, vr);
    while (vl == vr && vl.is_valid()) {
      force_vsplit(mesh_.data(vl).vhierarchy_node_handle());
      get_active_cuts(nh, vl, vr);
    }
    vsplit(nh, vl, vr);
  }
  void vsplit(VHierarchyNodeHandle nh, VdpmMesh::VertexHandle vl, VdpmMesh::VertexHandle vr) {
    const auto l = vh_.lchild_handle(nh), r = vh_.rchild_handle(nh);
    const auto v0 = vh_.vertex_handle(l), v1 = vh_.vertex_handle(r);
    mesh_.vertex_split(v0, v1, vl, vr);
    mesh_.set_point(v0, point(node_of_[static_cast<std::size_t>(l.idx())]));
    mesh_.set_point(v1, point(node_of_[static_cast<std::size_t>(r.idx())]));
    mesh_.data(v0).set_vhierarchy_node_handle(l);
    mesh_.data(v1).set_vhierarchy_node_handle(r);
    mesh_.status(v0).set_deleted(false);
    mesh_.status(v1).set_deleted(false);
    vfront_.remove(nh);
    vfront_.add(l);
    vfront_.add(r);
    ++splits;
  }
  void ecol(VHierarchyNodeHandle nh, VdpmMesh::HalfedgeHandle v0v1) {
    const auto l = vh_.lchild_handle(nh), r = vh_.rchild_handle(nh);
    const auto v0 = vh_.vertex_handle(l), v1 = vh_.vertex_handle(r);
    mesh_.collapse(v0v1);
    mesh_.set_point(v1, point(node_of_[static_cast<std::size_t>(nh.idx())]));
    mesh_.data(v0).set_vhierarchy_node_handle(l);
    mesh_.data(v1).set_vhierarchy_node_handle(nh);
    mesh_.status(v0).set_deleted(false);
    mesh_.status(v1).set_deleted(false);
    vfront_.add(nh);
    vfront_.remove(l);
    vfront_.remove(r);
    ++collapses;
  }
  bool ecol_legal(VHierarchyNodeHandle parent, VdpmMesh::HalfedgeHandle& v0v1) {
    const auto l = vh_.lchild_handle(parent), r = vh_.rchild_handle(parent);
    if (!vfront_.is_active(l) || !vfront_.is_active(r)) return false;
    v0v1 = mesh_.find_halfedge(vh_.vertex_handle(l), vh_.vertex_handle(r));
    return v0v1.is_valid() && mesh_.is_collapse_ok(v0v1);
  }
  void get_active_cuts(VHierarchyNodeHandle nh, VdpmMesh::VertexHandle& vl, VdpmMesh::VertexHandle& vr) {
    const VHierarchyNodeIndex lcut = vh_.fund_lcut_index(nh), rcut = vh_.fund_rcut_index(nh);
    vl = vr = VdpmMesh::InvalidVertexHandle;
    for (auto vv = mesh_.vv_iter(vh_.vertex_handle(nh)); vv.is_valid(); ++vv) {
      const VHierarchyNodeIndex ni = vh_.node_index(mesh_.data(*vv).vhierarchy_node_handle());
      if (!vl.is_valid() && vh_.is_ancestor(ni, lcut)) vl = *vv;
      if (!vr.is_valid() && vh_.is_ancestor(ni, rcut)) vr = *vv;
      if (vl.is_valid() && vr.is_valid()) break;
    }
  }

  const VertexHierarchy& h_;
  VdpmMesh mesh_;
  OpenMesh::VDPM::VHierarchy vh_;
  OpenMesh::VDPM::VFront vfront_;
  std::vector<VHierarchyNodeHandle> handle_of_;  // varmesh node -> VDPM node
  std::vector<Index> node_of_;                   // VDPM node -> varmesh node
};

// ---- the report ----

struct Options {
  std::string data = "/work/shared/data/meshes";
  int reps = 5;
  std::string only;
  bool quick = false;
};

bool want(const Options& o, const char* section) { return o.only.empty() || o.only == section; }

TriMesh load(const Options& o, const char* name) {
  const Stopwatch sw;
  TriMesh m = read_mesh(o.data + "/" + name);
  std::printf("read %s: %zu vertices, %zu faces (%.2f s)\n", name, m.num_vertices(), m.num_faces(), sw.lap().wall);
  return m;
}

std::string fmt(const char* f, double a) {
  char buf[64];
  std::snprintf(buf, sizeof buf, f, a);
  return buf;
}

#if VARMESH_HAVE_CGAL
// CGAL's Lindstrom-Turk edge collapse (Surface_mesh_simplification, LT cost and placement), stopped at the
// face count: the error reference of issue 3 (its peers.md figure is quoted from a CGAL run).
struct CgalResult {
  SimplifyResult simplified;
  std::size_t rejected_faces = 0;
};

// Stops when the mesh has at most `target` faces (CGAL's own predicates count edges).
struct StopAtFaces {
  std::size_t target;
  template <class F, class Profile>
  bool operator()(const F&, const Profile& p, std::size_t, std::size_t) const {
    return p.surface_mesh().number_of_faces() <= target;
  }
};

CgalResult run_cgal(const TriMesh& m, std::size_t target_faces) {
  using Kernel = CGAL::Simple_cartesian<double>;
  using Mesh = CGAL::Surface_mesh<Kernel::Point_3>;
  namespace SMS = CGAL::Surface_mesh_simplification;
  CgalResult out;
  const Stopwatch sw;
  Mesh mesh;
  std::vector<Mesh::Vertex_index> vh(m.num_vertices());
  for (std::size_t v = 0; v < m.num_vertices(); ++v)
    vh[v] = mesh.add_vertex(Kernel::Point_3(m.positions[v].x, m.positions[v].y, m.positions[v].z));
  for (std::size_t f = 0; f < m.num_faces(); ++f)
    if (mesh.add_face(vh[m.indices[3 * f]], vh[m.indices[3 * f + 1]], vh[m.indices[3 * f + 2]]) == Mesh::null_face())
      ++out.rejected_faces;
  SMS::edge_collapse(mesh, StopAtFaces{target_faces},
                     CGAL::parameters::get_cost(SMS::LindstromTurk_cost<Mesh>())
                         .get_placement(SMS::LindstromTurk_placement<Mesh>()));
  out.simplified.time = sw.lap();
  std::vector<Index> remap(mesh.num_vertices(), kInvalid);
  for (Mesh::Vertex_index v : mesh.vertices()) {
    const auto& p = mesh.point(v);
    remap[v.idx()] = static_cast<Index>(out.simplified.positions.size());
    out.simplified.positions.push_back({float(p.x()), float(p.y()), float(p.z())});
  }
  for (Mesh::Face_index f : mesh.faces())
    for (Mesh::Vertex_index v : CGAL::vertices_around_face(mesh.halfedge(f), mesh))
      out.simplified.indices.push_back(remap[v.idx()]);
  return out;
}
#endif

struct AnalysisRow {
  std::string mesh, method;
  std::size_t faces = 0;
  Lap time;
  Distance d;
  bool has_distance = false;
  std::string note;
};

void print_analysis(const std::vector<AnalysisRow>& rows) {
  std::printf("\n| mesh | method | faces out | CPU s (median) | wall s (median) | CPU time / meshopt | wall time / meshopt | "
              "RMS / diag (1e-4) | max / diag (1e-4) | notes |\n|---|---|---|---|---|---|---|---|---|---|\n");
  for (const auto& r : rows) {
    double ref = 0.0, ref_wall = 0.0;
    for (const auto& o : rows)
      if (o.mesh == r.mesh && o.method.rfind("meshoptimizer", 0) == 0) ref = o.time.cpu, ref_wall = o.time.wall;
    std::printf("| %s | %s | %zu | %.3f | %.3f | %s | %s | %s | %s | %s |\n", r.mesh.c_str(), r.method.c_str(), r.faces, r.time.cpu,
                r.time.wall, ref > 0 ? fmt("%.1fx", r.time.cpu / ref).c_str() : "-",
                ref_wall > 0 ? fmt("%.1fx", r.time.wall / ref_wall).c_str() : "-",
                r.has_distance ? fmt("%.2f", r.d.rms * 1e4).c_str() : "-",
                r.has_distance ? fmt("%.1f", r.d.max * 1e4).c_str() : "-", r.note.c_str());
  }
}

void analysis(const TriMesh& m, const char* name, int reps, std::vector<AnalysisRow>& rows) {
  const std::size_t target = std::max<std::size_t>(1, m.num_faces() / 100);
  std::printf("\n== analysis: %s, target %zu faces (1%% of %zu), %d repetitions ==\n", name, target, m.num_faces(), reps);
  std::fflush(stdout);
  Laps t_vm, t_par, t_q, t_full, t_lt, t_plain, t_mo, t_om, t_om_build;
  TriMesh vm_result, par_result, q_result, lt_result, plain_result;
  QemStats st1, stpar, stq, stf, stl, stp;
  std::size_t full_collapses = 0, full_base_faces = 0, mem = 0, nfaces = 0, depth = 0;
  SimplifyResult mo;
  OmResult om;
#if VARMESH_HAVE_CGAL
  CgalResult cg;
  Laps t_cg;
#endif
  // One timed analysis to 1 % of the faces; `tune` sets the variant's options. The first repetition keeps
  // its base mesh for the distance.
  auto to_one_percent = [&](int rep, QemStats& st, Laps& t, TriMesh& result, auto tune) {
    QemOptions opt;
    opt.target_faces = target;
    tune(opt);
    st = {};
    const Stopwatch sw;
    const VertexHierarchy h = build_vertex_hierarchy(m, opt, &st);
    t.add(sw.lap());
    if (rep == 0) result = mesh_after_collapses(h, h.num_collapses());
  };
  for (int i = 0; i < reps; ++i) {
    to_one_percent(i, st1, t_vm, vm_result, [](QemOptions&) {});
    to_one_percent(i, stpar, t_par, par_result, [](QemOptions& o) { o.threads = 2; });
    to_one_percent(i, stq, t_q, q_result, [](QemOptions& o) { o.lt_finish = 0.0; });
    to_one_percent(i, stp, t_plain, plain_result, [](QemOptions& o) {
      o.preserve_volume = false;
      o.lt_finish = 0.0;
    });
    to_one_percent(i, stl, t_lt, lt_result, [](QemOptions& o) { o.cost = CollapseCost::kLindstromTurk; });
    {
      stf = {};
      const Stopwatch sw;
      const VertexHierarchy h = build_vertex_hierarchy(m, QemOptions{}, &stf);
      t_full.add(sw.lap());
      full_collapses = h.num_collapses();
      full_base_faces = h.base_faces().size();
      mem = h.memory_bytes();
      nfaces = h.num_faces();
      depth = static_cast<std::size_t>(h.max_depth());
    }
    mo = run_meshopt(m, target);
    t_mo.add(mo.time);
    om = run_openmesh(m, target);
    t_om.add(om.simplified.time);
    t_om_build.add(om.build);
#if VARMESH_HAVE_CGAL
    cg = run_cgal(m, target);
    t_cg.add(cg.simplified.time);
#endif
    std::printf("  rep %d (CPU s): varmesh %.3f (1%%), %.3f CPU / %.3f wall (1%%, 2 threads), %.3f (1%%, quadrics to the end), %.3f (1%%, plain GH97), %.3f "
                "(smallest base), %.3f (1%%, Lindstrom-Turk cost); meshopt %.3f; OpenMesh %.3f\n", i, t_vm.cpu.back(),
                t_par.cpu.back(), t_par.wall.back(),
                t_q.cpu.back(), t_plain.cpu.back(),
                t_full.cpu.back(), t_lt.cpu.back(), t_mo.cpu.back(), t_om.cpu.back());
    std::fflush(stdout);
  }
  const Distance d_vm = distance_to(m, vm_result.positions, vm_result.indices);
  const Distance d_par = distance_to(m, par_result.positions, par_result.indices);
  const Distance d_q = distance_to(m, q_result.positions, q_result.indices);
  const Distance d_lt = distance_to(m, lt_result.positions, lt_result.indices);
  const Distance d_plain = distance_to(m, plain_result.positions, plain_result.indices);
  const Distance d_mo = distance_to(m, mo.positions, mo.indices);
  const Distance d_om = distance_to(m, om.simplified.positions, om.simplified.indices);
  char buf[320];
  std::snprintf(buf, sizeof buf,
                "%zu collapses (rejected: link %zu, flip %zu); records the whole hierarchy from the original mesh down to "
                "this 1%% base mesh; quadric order, volume kept, Lindstrom-Turk from 4x the target on",
                st1.collapses, st1.rejected_link, st1.rejected_flip);
  rows.push_back({name, "varmesh build_vertex_hierarchy, target_faces = 1%", vm_result.num_faces(), t_vm.med(), d_vm, true, buf});
  std::snprintf(buf, sizeof buf,
                "%zu collapses (rejected: link %zu, flip %zu); QemOptions::threads = 2: two parts at once, then the "
                "whole (compare wall times)", stpar.collapses, stpar.rejected_link, stpar.rejected_flip);
  rows.push_back({name, "varmesh build_vertex_hierarchy, target_faces = 1%, 2 threads", par_result.num_faces(), t_par.med(),
                  d_par, true, buf});
  std::snprintf(buf, sizeof buf,
                "%zu collapses (rejected: link %zu, flip %zu); QemOptions::lt_finish = 0: quadric order and "
                "volume-kept placement to the end", stq.collapses, stq.rejected_link, stq.rejected_flip);
  rows.push_back({name, "varmesh build_vertex_hierarchy, target_faces = 1%, quadrics to the end", q_result.num_faces(),
                  t_q.med(), d_q, true, buf});
  std::snprintf(buf, sizeof buf,
                "%zu collapses (rejected: link %zu, flip %zu); QemOptions::preserve_volume = false, lt_finish = 0: "
                "vs at the quadric's minimiser (GH97)", stp.collapses, stp.rejected_link, stp.rejected_flip);
  rows.push_back({name, "varmesh build_vertex_hierarchy, target_faces = 1%, plain quadric placement", plain_result.num_faces(),
                  t_plain.med(), d_plain, true, buf});
  std::snprintf(buf, sizeof buf, "%zu collapses down to a %zu-face base mesh, depth %zu; hierarchy %.1f bytes per original face",
                full_collapses, full_base_faces, depth, static_cast<double>(mem) / static_cast<double>(nfaces));
  rows.push_back({name, "varmesh build_vertex_hierarchy, smallest base mesh", full_base_faces, t_full.med(), {}, false, buf});
  std::snprintf(buf, sizeof buf,
                "%zu collapses (rejected: link %zu, flip %zu); QemOptions::cost = kLindstromTurk (memoryless)",
                stl.collapses, stl.rejected_link, stl.rejected_flip);
  rows.push_back({name, "varmesh build_vertex_hierarchy, target_faces = 1%, Lindstrom-Turk cost", lt_result.num_faces(),
                  t_lt.med(), d_lt, true, buf});
  rows.push_back({name, "meshoptimizer 0.18 meshopt_simplify", mo.indices.size() / 3, t_mo.med(), d_mo, true,
                  "keeps original vertex positions; no hierarchy"});
  std::snprintf(buf, sizeof buf,
                "incl. %.3f s CPU to build its halfedge mesh; %zu complex faces rejected; half-edge collapses; no hierarchy",
                t_om_build.med().cpu, om.rejected_faces);
  rows.push_back({name, "OpenMesh 9.0 Decimater + ModQuadric", om.simplified.indices.size() / 3, t_om.med(), d_om, true, buf});
#if VARMESH_HAVE_CGAL
  const Distance d_cg = distance_to(m, cg.simplified.positions, cg.simplified.indices);
  std::snprintf(buf, sizeof buf, "CGAL %s Surface_mesh, LindstromTurk cost + placement; %zu non-manifold faces rejected; no hierarchy",
                CGAL_VERSION_STR, cg.rejected_faces);
  rows.push_back({name, "CGAL Lindstrom-Turk edge_collapse", cg.simplified.indices.size() / 3, t_cg.med(), d_cg, true, buf});
  std::printf("  error ratio varmesh / CGAL Lindstrom-Turk: RMS %.2f, max %.2f (goal: at most 1.1); quadrics to the "
              "end: RMS %.2f, max %.2f; plain GH97: RMS %.2f, max %.2f; with QemOptions::cost = kLindstromTurk: RMS "
              "%.2f, max %.2f\n",
              d_vm.rms / d_cg.rms, d_vm.max / d_cg.max, d_q.rms / d_cg.rms, d_q.max / d_cg.max, d_plain.rms / d_cg.rms,
              d_plain.max / d_cg.max,
              d_lt.rms / d_cg.rms, d_lt.max / d_cg.max);
#else
  std::printf("  CGAL not found at build time: no Lindstrom-Turk reference (apt-get install libcgal-dev)\n");
#endif
}

struct SynthRow {
  std::string mesh, hierarchy, library;
  std::size_t splits = 0, collapses = 0;
  Lap split_ns, col_ns;  // per operation
  std::string reached;
};

void print_synthesis(const std::vector<SynthRow>& rows) {
  std::printf("\n| mesh | hierarchy | library | vsplits | ns/vsplit CPU (wall) | M vsplits/s (CPU) | ecols | ns/ecol CPU (wall) | "
              "M ecols/s (CPU) | end states |\n|---|---|---|---|---|---|---|---|---|---|\n");
  for (const auto& r : rows)
    std::printf("| %s | %s | %s | %zu | %.0f (%.0f) | %.2f | %zu | %.0f (%.0f) | %.2f | %s |\n", r.mesh.c_str(),
                r.hierarchy.c_str(), r.library.c_str(), r.splits, r.split_ns.cpu, r.split_ns.wall, 1e3 / r.split_ns.cpu,
                r.collapses, r.col_ns.cpu, r.col_ns.wall, 1e3 / r.col_ns.cpu, r.reached.c_str());
}

Lap per_op(Lap t, std::size_t ops) {
  const double n = static_cast<double>(std::max<std::size_t>(ops, 1));
  return {t.wall * 1e9 / n, t.cpu * 1e9 / n};
}

SynthRow synth_varmesh(const VertexHierarchy& h, const char* mesh, const std::string& hname, int reps) {
  SrMesh sr(h);
  Laps s, c;
  SynthRow row{mesh, hname, "varmesh SrMesh (Kim-Lee)", 0, 0, {}, {}, ""};
  bool all_full = true, all_base = true;
  std::size_t dc = 0;
  for (int i = 0; i < reps; ++i) {
    sr.reset_stats();
    Stopwatch sw;
    row.splits = sr.refine_all();
    s.add(per_op(sw.lap(), row.splits));
    all_full = all_full && sr.num_active_vertices() == h.num_leaves() && sr.num_faces() == h.num_faces();
    const Stopwatch sw2;
    row.collapses = sr.coarsen_all();
    c.add(per_op(sw2.lap(), row.collapses));
    all_base = all_base && sr.num_active_vertices() == h.num_roots() && sr.num_faces() == h.base_faces().size();
    dc += sr.stats().degenerate_cases;
  }
  row.split_ns = s.med();
  row.col_ns = c.med();
  row.reached = std::string(all_full ? "full mesh" : "NOT the full mesh") + " / " + (all_base ? "base mesh" : "NOT the base mesh") +
                " every time; #DC " + std::to_string(dc);
  return row;
}

SynthRow synth_vdpm(const VertexHierarchy& h, const char* mesh, const std::string& hname, int reps) {
  SynthRow row{mesh, hname, "OpenMesh 9.0 VDPM loop", 0, 0, {}, {}, ""};
  VdpmDriver vd(h);  // throws when the hierarchy does not fit
  Laps s, c;
  std::size_t fv = 0, ff = 0, bv = 0, bf = 0;
  for (int i = 0; i < reps; ++i) {
    vd.splits = vd.collapses = 0;
    // The app's adaptive_refinement pass, repeated until the mesh stops changing.
    Stopwatch sw;
    for (std::size_t before = ~std::size_t{0}; vd.num_faces() != before;) {
      before = vd.num_faces();
      vd.adapt([](Index) { return true; });
    }
    row.splits = vd.splits;
    s.add(per_op(sw.lap(), row.splits));
    fv = vd.num_active();
    ff = vd.num_faces();
    const Stopwatch sw2;
    for (std::size_t before = ~std::size_t{0}; vd.num_faces() != before;) {
      before = vd.num_faces();
      vd.adapt([](Index) { return false; });
    }
    row.collapses = vd.collapses;
    c.add(per_op(sw2.lap(), row.collapses));
    bv = vd.num_active();
    bf = vd.num_faces();
  }
  row.split_ns = s.med();
  row.col_ns = c.med();
  row.reached = "refined to " + std::to_string(fv) + " v / " + std::to_string(ff) + " f (full: " + std::to_string(h.num_leaves()) +
                " / " + std::to_string(h.num_faces()) + "); coarsened to " + std::to_string(bv) + " v / " + std::to_string(bf) +
                " f (base: " + std::to_string(h.num_roots()) + " / " + std::to_string(h.base_faces().size()) + ")";
  return row;
}

void synthesis(const Options& o, const TriMesh& m, const char* name, std::vector<SynthRow>& rows) {
  std::printf("\n== synthesis: %s ==\n", name);
  std::fflush(stdout);
  QemStats st;
  const VertexHierarchy h = build_vertex_hierarchy(m, QemOptions{}, &st);
  const std::string hname = "smallest base, depth " + std::to_string(h.max_depth());
  std::printf("hierarchy: %zu leaves, %zu collapses, %zu roots, %zu base faces, depth %d, built in %.2f s wall\n", h.num_leaves(),
              h.num_collapses(), h.num_roots(), h.base_faces().size(), h.max_depth(), st.seconds);
  const double sr_bytes = static_cast<double>(SrMesh(h).memory_bytes());
  std::printf("memory: VertexHierarchy::memory_bytes() = %zu = %.1f bytes per original face; SrMesh::memory_bytes() %.1f "
              "bytes per original face\n",
              h.memory_bytes(), static_cast<double>(h.memory_bytes()) / static_cast<double>(h.num_faces()),
              sr_bytes / static_cast<double>(h.num_faces()));
  rows.push_back(synth_varmesh(h, name, hname, o.reps));
  try {
    rows.push_back(synth_vdpm(h, name, hname, std::max(1, o.reps / 2)));
    return;
  } catch (const std::exception& e) {
    std::printf("OpenMesh VDPM cannot take this hierarchy: %s; rebuilding with a depth limit for a side-by-side run\n", e.what());
  }
  // VDPM packs <tree-id, node-id> in 32 bits: cap the depth so that the hierarchy fits, and run both on it.
  int tree_bits = static_cast<int>(std::bit_width(h.num_roots() - 1));
  for (int attempt = 0; attempt < 3; ++attempt, ++tree_bits) {
    QemOptions opt;
    opt.max_depth = 31 - tree_bits;
    const VertexHierarchy hd = build_vertex_hierarchy(m, opt, &st);
    const std::string hd_name = "smallest base with max_depth " + std::to_string(opt.max_depth) + " (" +
                                std::to_string(hd.num_roots()) + " roots)";
    try {
      rows.push_back(synth_vdpm(hd, name, hd_name, std::max(1, o.reps / 2)));
      rows.push_back(synth_varmesh(hd, name, hd_name, o.reps));
      return;
    } catch (const std::exception& e) {
      std::printf("  %s: %s\n", hd_name.c_str(), e.what());
    }
  }
}

Query orbit_query(const Camera& cam, float pixels) {
  Query q;
  q.criterion = Criterion::any_of({Criterion::outside_frustum(cam.frustum()), Criterion::back_facing(cam.eye),
                                   Criterion::screen_error(cam, 1080.0f, pixels)});
  return q;
}

void frames(const Options& o, const TriMesh& m, const char* name) {
  std::printf("\n== per-frame update: %s, 200-frame orbit ==\n", name);
  std::fflush(stdout);
  QemStats st;
  const VertexHierarchy h = build_vertex_hierarchy(m, QemOptions{}, &st);
  const Sphere s = bounding_sphere(m.positions.data(), m.positions.size());
  constexpr int kFrames = 200;
  // Camera i of an orbit of `per_orbit` frames.
  auto orbit_camera = [&](int i, int per_orbit) {
    const float a = 6.2831853f * static_cast<float>(i) / static_cast<float>(per_orbit);
    return frame_sphere(s.center, s.radius, glm::vec3(std::sin(a), 0.35f, std::cos(a)), 45.0f, 16.0f / 9.0f,
                        glm::vec3(0.0f, 1.0f, 0.0f));
  };
  std::vector<Camera> cams;
  for (int i = 0; i <= kFrames; ++i) cams.push_back(orbit_camera(i, kFrames));
  SrMesh a(h), b(h), c(h);
  // Screen-space tolerance (pixels on a 1080-line viewport) giving about 17k faces on average over 8 views.
  float lo = 0.01f, hi = 100.0f;
  for (int it = 0; it < 30; ++it) {
    const float mid = std::sqrt(lo * hi);
    double sum = 0.0;
    for (int i = 0; i < kFrames; i += kFrames / 8) {
      extract(a, orbit_query(cams[static_cast<std::size_t>(i)], mid));
      sum += static_cast<double>(a.num_faces());
    }
    if (sum / 8.0 > 17000.0) lo = mid; else hi = mid;
  }
  const float tol = hi;
  std::vector<Query> queries;
  for (const Camera& cam : cams) queries.push_back(orbit_query(cam, tol));

  Laps t_up, t_ex, t_co, t_vd;
  std::vector<double> faces;
  std::size_t finer = 0, coarser = 0, max_extra = 0, co_diff = 0, coarsened = 0, refined = 0, vd_diff = 0;
  std::size_t co_evaluated = 0, co_reused = 0;
  QueryCoherence coherence;
  const int orbits = std::max(1, o.reps / 2 + 1);
  std::vector<std::size_t> faces_ex(kFrames + 1), faces_up(kFrames + 1);
  std::unique_ptr<VdpmDriver> vd;
  std::string vdpm_note;
  try {
    vd = std::make_unique<VdpmDriver>(h);
  } catch (const std::exception& e) {
    vdpm_note = e.what();
  }
  for (int rep = 0; rep < orbits; ++rep) {
    // Each method runs a whole orbit on its own (frame i starts from frame i-1's state), so it keeps its
    // data in cache as a renderer would.
    for (int i = 1; i <= kFrames; ++i) {
      const Stopwatch sw;
      extract(b, queries[static_cast<std::size_t>(i)]);
      t_ex.add(sw.lap());
      faces_ex[static_cast<std::size_t>(i)] = b.num_faces();
    }
    extract(a, queries[0]);
    for (int i = 1; i <= kFrames; ++i) {
      const Stopwatch sw;
      const QueryStats qs = update(a, queries[static_cast<std::size_t>(i)]);
      t_up.add(sw.lap());
      const std::size_t fu = a.num_faces(), fe = faces_ex[static_cast<std::size_t>(i)];
      faces_up[static_cast<std::size_t>(i)] = fu;
      faces.push_back(static_cast<double>(fu));
      finer += fu > fe;
      coarser += fu < fe;
      max_extra = std::max(max_extra, fu > fe ? fu - fe : fe - fu);
      coarsened += qs.coarsened;
      refined += qs.refined;
    }
    // update() with frame-to-frame coherence (the QueryCoherence persists across orbits, as in an application).
    extract(c, queries[0]);
    for (int i = 1; i <= kFrames; ++i) {
      const Stopwatch sw;
      const QueryStats qs = update(c, queries[static_cast<std::size_t>(i)], coherence);
      t_co.add(sw.lap());
      co_diff += c.num_faces() != faces_up[static_cast<std::size_t>(i)];
      if (rep == 0) {
        co_evaluated += qs.evaluated;
        co_reused += qs.reused;
      }
    }
    if (vd) {
      const Query& q0 = queries[0];
      vd->adapt([&](Index v) { return q0.wants(h.bound(v)); });
      for (int i = 1; i <= kFrames; ++i) {
        const Query& q = queries[static_cast<std::size_t>(i)];
        const Stopwatch sw;
        vd->adapt([&](Index v) { return q.wants(h.bound(v)); });
        t_vd.add(sw.lap());
        vd_diff += vd->num_faces() != faces_ex[static_cast<std::size_t>(i)];
      }
    }
  }
  // The same comparison with the camera five times slower (a fifth of the orbit in as many frames): more
  // answers keep their margins from one frame to the next, which is what coherence needs to pay off for a
  // criterion this cheap (see QueryCoherence in multitri/query.hpp).
  constexpr int kSlowdown = 5;
  std::vector<Query> slow;
  for (int i = 0; i <= kFrames; ++i) slow.push_back(orbit_query(orbit_camera(i, kSlowdown * kFrames), tol));
  Laps s_up, s_co;
  std::size_t s_diff = 0, s_evaluated = 0, s_reused = 0;
  QueryCoherence slow_coherence;
  for (int rep = 0; rep < orbits; ++rep) {
    extract(a, slow[0]);
    for (int i = 1; i <= kFrames; ++i) {
      const Stopwatch sw;
      update(a, slow[static_cast<std::size_t>(i)]);
      s_up.add(sw.lap());
      faces_up[static_cast<std::size_t>(i)] = a.num_faces();
    }
    extract(c, slow[0]);
    for (int i = 1; i <= kFrames; ++i) {
      const Stopwatch sw;
      const QueryStats qs = update(c, slow[static_cast<std::size_t>(i)], slow_coherence);
      s_co.add(sw.lap());
      s_diff += c.num_faces() != faces_up[static_cast<std::size_t>(i)];
      if (rep == 0) {
        s_evaluated += qs.evaluated;
        s_reused += qs.reused;
      }
    }
  }
  const std::size_t n = t_up.size();
  std::printf("hierarchy: %zu leaves, %zu roots, depth %d; tolerance %.3f px on a 1080-line viewport (16:9, 45 deg fov), "
              "culling by frustum and back-facing normal cones; faces median %.0f, min %.0f, max %.0f\n",
              h.num_leaves(), h.num_roots(), h.max_depth(), static_cast<double>(tol), median(faces),
              *std::min_element(faces.begin(), faces.end()), *std::max_element(faces.begin(), faces.end()));
  std::printf("update() vs extract() face counts: update finer in %zu, coarser in %zu of %zu frames (largest difference %zu "
              "faces); per frame update() coarsens %.1f and refines %.1f nodes on average; update() with coherence differs "
              "from update() in %zu frames and evaluates %.0f / reuses %.0f answers per frame (mean, first orbit); VDPM "
              "differs from extract() in %zu frames\n",
              finer, coarser, n, max_extra, static_cast<double>(coarsened) / static_cast<double>(n),
              static_cast<double>(refined) / static_cast<double>(n), co_diff,
              static_cast<double>(co_evaluated) / kFrames, static_cast<double>(co_reused) / kFrames, vd_diff);
  auto row = [&](const char* what, const Laps& l) {
    const Lap md = l.med(), p = l.p95();
    std::printf("| %s | %.0f | %.3f | %.3f | %.3f | %.3f |\n", what, median(faces), md.cpu * 1e3, p.cpu * 1e3, md.wall * 1e3,
                p.wall * 1e3);
  };
  std::printf("\n| method (bunny orbit, %d x %d frames) | faces (median) | CPU ms/frame median | CPU p95 | wall ms/frame median | "
              "wall p95 |\n|---|---|---|---|---|---|\n", orbits, kFrames);
  row("varmesh update() (incremental)", t_up);
  row("varmesh extract() (from scratch)", t_ex);
  row("varmesh update() with QueryCoherence", t_co);
  if (vd) row("OpenMesh VDPM loop, same hierarchy and criterion", t_vd);
  else std::printf("OpenMesh VDPM not run: %s\n", vdpm_note.c_str());
  std::printf("(extract / update CPU median = %.1fx; update / coherent update = %.2fx", t_ex.med().cpu / t_up.med().cpu,
              t_up.med().cpu / t_co.med().cpu);
  if (vd) std::printf("; VDPM / update = %.1fx", t_vd.med().cpu / t_up.med().cpu);
  std::printf(")\n");
  auto reused_pct = [](std::size_t evaluated, std::size_t reused) {
    return 100.0 * static_cast<double>(reused) / static_cast<double>(std::max<std::size_t>(1, evaluated + reused));
  };
  const double step = static_cast<double>(glm::length(cams[1].eye - cams[0].eye) / glm::length(cams[0].eye - s.center));
  std::printf("coherence: %.1f deg per frame (the eye moves %.1f%% of its distance to the model's centre) reuses %.0f%% of the "
              "answers. A reused answer saves one evaluation of this cheap criterion (a few compares, ns) for a record "
              "lookup, but each answer it re-evaluates costs is_fine_with_margin(), about 2-3 times is_fine(), and the "
              "ones it re-evaluates lie near a decision boundary: it breaks even near 70%% reuse (see QueryCoherence "
              "in multitri/query.hpp). With the camera %dx slower (%.2f deg per frame, %d frames) it reuses %.0f%%: "
              "update() %.3f ms, with coherence %.3f ms CPU median (update / coherent update = %.2fx; coherence differs from update() in %zu frames)\n",
              360.0 / kFrames, 100.0 * step, reused_pct(co_evaluated, co_reused), kSlowdown,
              360.0 / (kSlowdown * kFrames), kFrames, reused_pct(s_evaluated, s_reused), s_up.med().cpu * 1e3,
              s_co.med().cpu * 1e3, s_up.med().cpu / s_co.med().cpu, s_diff);
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  if (const char* env = std::getenv("VARMESH_DATA")) o.data = std::string(env) + "/meshes";
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--data" && i + 1 < argc) o.data = argv[++i];
    else if (a == "--reps" && i + 1 < argc) o.reps = std::max(1, std::atoi(argv[++i]));
    else if (a == "--only" && i + 1 < argc) o.only = argv[++i];
    else if (a == "--quick") o.quick = true;
    else {
      std::fprintf(stderr, "usage: %s [--data DIR] [--reps N] [--only analysis|synthesis|frames] [--quick]\n", argv[0]);
      return 2;
    }
  }
  try {
    const char* bunny_name = "bun_zipper_35947v.obj";
    const char* dragon_name = "dragon_vrip_437645v_binary_le.ply";
    const TriMesh bunny = load(o, bunny_name);
    TriMesh dragon;
    if (!o.quick && (want(o, "analysis") || want(o, "synthesis"))) dragon = load(o, dragon_name);
    if (want(o, "analysis")) {
      std::vector<AnalysisRow> rows;
      analysis(bunny, "bunny", o.reps, rows);
      if (!o.quick) analysis(dragon, "dragon", std::max(1, (o.reps + 1) / 2), rows);
      print_analysis(rows);
    }
    if (want(o, "synthesis")) {
      std::vector<SynthRow> rows;
      synthesis(o, bunny, "bunny", rows);
      if (!o.quick) synthesis(o, dragon, "dragon", rows);
      print_synthesis(rows);
    }
    if (want(o, "frames")) frames(o, bunny, "bunny");
  } catch (const std::exception& e) {
    std::fprintf(stderr, "varmesh_pm_bench: %s\n", e.what());
    return 1;
  }
  return 0;
}
