// Uniform Catmull-Clark against OpenSubdiv 3.5 (Far), one program, the same polygon mesh, the same level.
//
// What is timed ("refine + positions"), per library, from the PolyMesh / TopologyDescriptor to the final
// vertex positions of level L:
//  - varmesh: subdivide(poly, SubdivScheme::kCatmullClark, 2 L, {keep_last_edges = false}) (double xyz);
//  - OpenSubdiv: TopologyRefinerFactory<TopologyDescriptor>::Create (SCHEME_CATMARK, VTX_BOUNDARY_EDGE_ONLY)
//    + RefineUniform(L) (fullTopologyInLastLevel = false, default vertex order) + PrimvarRefinerReal<double>
//    ::Interpolate level by level, ping-ponging between two buffers (only the last level's positions are
//    kept: the cheapest way to use the API for this task); `--osd-float` adds the same with float xyz.
// Each library runs in its own forked children (--reps children per library, libraries alternating). A
// child does one cold run (a fresh process: every page it uses is faulted in) and then --warm more runs,
// each after the previous result was freed; it reports wall and thread-CPU times and its peak memory:
// getrusage(RUSAGE_SELF).ru_maxrss after the cold run minus VmRSS before it (the peak is first reset with
// /proc/self/clear_refs "5", so the parent's history cannot leak in). Bytes per face = that increase /
// final faces; the result (final topology + positions) is alive at the end of the cold run for both.
// Faces per second = final quads / median time. varmesh's SubdivMesh::memory_bytes() / face is printed too.
//
// Then, in this process: `--phases` breaks varmesh's time down from public functions (thread CPU time):
// make_subdiv_topology, refine_subdiv_topology per level, and the position steps as marginal costs of
// subdivide() with one more binary step; it also models the live bytes at the peak. Unless --no-verify,
// both results are compared vertex for vertex: varmesh's numbering is mapped to OpenSubdiv's level by level
// (old vertices via GetVertexChildVertex, face points via the matched face and GetFaceChildVertex, edge
// points via FindEdge + GetEdgeChildVertex, child faces matched by their corner vertex; the two numberings
// agree at level 1 only), and the largest |ours - osd| over the bounding-box diagonal is printed.
//
// usage: varmesh_subdiv_bench [--mesh FILE] [--level L] [--reps N] [--warm W] [--only varmesh|osd]
//                             [--phases] [--no-pair] [--osd-float] [--no-verify] [--torus NUxNV]
//   FILE defaults to /work/shared/data/meshes/bunny_npm_1839v.obj (1,837 quads after pair_triangles:
//   1.88 M faces at level 5); when it is missing, a generated 81 x 34 quad torus (2,754 quads, 2.82 M
//   faces at level 5). --no-pair feeds the triangles as they are. Defaults: --level 5 --reps 5 --warm 2.
#include <fcntl.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>

#include "bench_timing.hpp"
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <glm/geometric.hpp>
#include <glm/vec3.hpp>
#include <opensubdiv/far/primvarRefiner.h>
#include <opensubdiv/far/topologyDescriptor.h>
#include <opensubdiv/far/topologyRefinerFactory.h>
#include <opensubdiv/version.h>

#include "fourk/poly_mesh.hpp"
#include "fourk/subdiv.hpp"
#include "multitri/mesh_io.hpp"

using namespace varmesh;
namespace Far = OpenSubdiv::Far;
namespace Sdc = OpenSubdiv::Sdc;

namespace {

double now_ms() {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now().time_since_epoch()).count();
}
double cpu_ms() { return 1e3 * varmesh::bench::thread_cpu_seconds(); }
long status_kb(const char* key) {  // VmRSS, VmHWM, ... from /proc/self/status
  FILE* f = std::fopen("/proc/self/status", "r");
  if (!f) return -1;
  char line[256];
  long v = -1;
  const std::size_t n = std::strlen(key);
  while (std::fgets(line, sizeof line, f))
    if (std::strncmp(line, key, n) == 0 && line[n] == ':') {
      v = std::atol(line + n + 1);
      break;
    }
  std::fclose(f);
  return v;
}
long maxrss_kb() {
  rusage ru{};
  getrusage(RUSAGE_SELF, &ru);
  return ru.ru_maxrss;
}
bool reset_peak() {
  const int fd = open("/proc/self/clear_refs", O_WRONLY);
  if (fd < 0) return false;
  const bool ok = write(fd, "5", 1) == 1;
  close(fd);
  return ok;
}

using varmesh::bench::median;

// ---------------------------------------------------------------- OpenSubdiv

template <class Real>
struct OsdVertex {
  Real p[3];
  void Clear(void* = nullptr) { p[0] = p[1] = p[2] = 0; }
  void AddWithWeight(const OsdVertex& s, Real w) {
    p[0] += w * s.p[0];
    p[1] += w * s.p[1];
    p[2] += w * s.p[2];
  }
};

struct OsdInput {
  std::vector<int> verts_per_face, corners;
  int num_vertices = 0;
};

OsdInput osd_input(const PolyMesh& m) {
  OsdInput in;
  in.num_vertices = static_cast<int>(m.num_vertices());
  for (std::size_t f = 0; f < m.num_faces(); ++f) in.verts_per_face.push_back(static_cast<int>(m.face_size(f)));
  in.corners.assign(m.corners.begin(), m.corners.end());
  return in;
}

std::unique_ptr<Far::TopologyRefiner> osd_create(const OsdInput& in) {
  Far::TopologyDescriptor desc;
  desc.numVertices = in.num_vertices;
  desc.numFaces = static_cast<int>(in.verts_per_face.size());
  desc.numVertsPerFace = in.verts_per_face.data();
  desc.vertIndicesPerFace = in.corners.data();
  Sdc::Options sdc;
  sdc.SetVtxBoundaryInterpolation(Sdc::Options::VTX_BOUNDARY_EDGE_ONLY);
  using Factory = Far::TopologyRefinerFactory<Far::TopologyDescriptor>;
  std::unique_ptr<Far::TopologyRefiner> r(Factory::Create(desc, Factory::Options(Sdc::SCHEME_CATMARK, sdc)));
  if (!r) {
    std::fprintf(stderr, "OpenSubdiv rejected the mesh\n");
    std::exit(2);
  }
  return r;
}

template <class Real>
struct OsdResult {
  std::unique_ptr<Far::TopologyRefiner> refiner;
  std::unique_ptr<OsdVertex<Real>[]> positions;  // the last level's
  double t_create = 0, t_refine = 0, t_primvar = 0;
};

template <class Real>
OsdResult<Real> run_osd(const OsdInput& in, const PolyMesh& poly, int level) {
  OsdResult<Real> r;
  double t0 = now_ms();
  r.refiner = osd_create(in);
  double t1 = now_ms();
  Far::TopologyRefiner::UniformOptions uo(level);
  uo.fullTopologyInLastLevel = false;
  r.refiner->RefineUniform(uo);
  double t2 = now_ms();
  using V = OsdVertex<Real>;
  std::unique_ptr<V[]> src(new V[poly.num_vertices()]);
  for (std::size_t v = 0; v < poly.num_vertices(); ++v)
    for (int c = 0; c < 3; ++c) src[v].p[c] = static_cast<Real>(poly.positions[v][c]);
  Far::PrimvarRefinerReal<Real> primvar(*r.refiner);
  for (int l = 1; l <= level; ++l) {
    std::unique_ptr<V[]> dst(new V[static_cast<std::size_t>(r.refiner->GetLevel(l).GetNumVertices())]);
    V* s = src.get();
    V* d = dst.get();
    primvar.Interpolate(l, s, d);
    src.swap(dst);
  }
  r.positions = std::move(src);
  double t3 = now_ms();
  r.t_create = t1 - t0;
  r.t_refine = t2 - t1;
  r.t_primvar = t3 - t2;
  return r;
}

// ---------------------------------------------------------------- forked runs

struct RunReport {
  double wall_ms = 0, cpu_ms = 0;
  double t_create = 0, t_refine = 0, t_primvar = 0;  // OpenSubdiv's parts
  long base_kb = 0, peak_kb = 0, start_maxrss_kb = 0, hwm_kb = 0;
  std::uint64_t faces = 0, vertices = 0, lib_bytes = 0;
  int peak_reset = 0;
  double checksum = 0;
  int warm = 0;                        // warm runs after the cold one, in the same child
  double warm_wall[16] = {}, warm_cpu[16] = {}, warm_refine[16] = {}, warm_primvar[16] = {};
};

// Runs `body` in a forked child: once cold (timed; the memory is measured over this run), then `warm` more
// times (each after the previous result was freed: the allocator reuses what it kept, as a program that
// subdivides repeatedly would). `body` fills the timing/size fields, the child adds the memory.
RunReport in_child(const std::function<void(RunReport&)>& body, int warm) {
  int fds[2];
  if (pipe(fds) != 0) {
    std::perror("pipe");
    std::exit(2);
  }
  std::fflush(stdout);
  const pid_t pid = fork();
  if (pid < 0) {
    std::perror("fork");
    std::exit(2);
  }
  if (pid == 0) {
    close(fds[0]);
    RunReport r;
    r.peak_reset = reset_peak() ? 1 : 0;
    r.base_kb = status_kb("VmRSS");
    r.start_maxrss_kb = maxrss_kb();
    body(r);
    r.peak_kb = maxrss_kb();
    r.hwm_kb = status_kb("VmHWM");
    r.warm = std::min(warm, 16);
    for (int w = 0; w < r.warm; ++w) {
      RunReport x;
      body(x);
      r.warm_wall[w] = x.wall_ms;
      r.warm_cpu[w] = x.cpu_ms;
      r.warm_refine[w] = x.t_refine;
      r.warm_primvar[w] = x.t_primvar;
    }
    const ssize_t w = write(fds[1], &r, sizeof r);
    _exit(w == static_cast<ssize_t>(sizeof r) ? 0 : 3);
  }
  close(fds[1]);
  RunReport r;
  std::size_t got = 0;
  while (got < sizeof r) {
    const ssize_t n = read(fds[0], reinterpret_cast<char*>(&r) + got, sizeof r - got);
    if (n <= 0) break;
    got += static_cast<std::size_t>(n);
  }
  close(fds[0]);
  int status = 0;
  waitpid(pid, &status, 0);
  if (got != sizeof r || !WIFEXITED(status) || WEXITSTATUS(status) != 0) {
    std::fprintf(stderr, "child failed (status %d)\n", status);
    std::exit(2);
  }
  return r;
}

SubdivMesh run_ours(const PolyMesh& poly, int level) {
  SubdivOptions o;
  o.keep_last_edges = false;
  return subdivide(poly, SubdivScheme::kCatmullClark, 2 * level, o);
}

// ---------------------------------------------------------------- phases

// A position step is a small difference of two larger times, so noise can swamp it: a difference of two
// medians came out negative with two reps. The difference is taken within each rep instead, where the runs
// were made back to back, and the median of those per-rep differences is printed. Where that median is not
// above half the range (max - min) of the per-rep differences, the reps disagree by more than the step
// itself: the cell says "<noise" with that half range instead of a number. With two reps this flags
// exactly the steps that one rep measured as zero or negative; with one rep, a step of zero or less.
struct StepTime {
  double ms = 0;     // median of the per-rep differences
  double noise = 0;  // half the range of the per-rep differences
  bool swamped() const { return ms <= noise; }
};

StepTime step_time(const std::vector<double>& per_rep) {
  const auto [lo, hi] = std::minmax_element(per_rep.begin(), per_rep.end());
  return {median(per_rep), (*hi - *lo) / 2};
}

std::string step_cell(const StepTime& t) {
  char buf[32];
  if (t.swamped()) std::snprintf(buf, sizeof buf, "<noise %.2f", t.noise);
  else std::snprintf(buf, sizeof buf, "%.2f", t.ms);
  return buf;
}

// Where varmesh's time goes, from public functions only (subdivide's position steps run in place inside
// the library and are not callable alone): make_subdiv_topology and refine_subdiv_topology level by level
// are timed directly; the position steps are the marginal cost of one more binary step of subdivide()
// (T(s + 1) - T(s), keep_last_edges = true so every refine builds edges, minus the refine timed alone);
// all as thread CPU time (the machine is shared);
// and the whole subdivide() call (keep_last_edges = false) as run by the benchmark. Also the live bytes
// at the peak, from the capacities of the arrays alive during the last refine.
void phases(const PolyMesh& poly, int level, int reps) {
  const int steps = 2 * level;
  std::vector<double> t_topo, t_whole;
  std::vector<std::vector<double>> t_refine(level), t_upto(steps + 1);
  std::vector<double> t_last_refine_noedges;
  for (int rep = 0; rep < reps; ++rep) {
    double a = cpu_ms();
    SubdivTopology topo = make_subdiv_topology(poly);
    t_topo.push_back(cpu_ms() - a);
    for (int l = 0; l < level; ++l) {
      a = cpu_ms();
      SubdivTopology child = refine_subdiv_topology(topo, true);
      t_refine[l].push_back(cpu_ms() - a);
      if (l + 1 == level) {
        child = SubdivTopology();
        a = cpu_ms();
        child = refine_subdiv_topology(topo, false);
        t_last_refine_noedges.push_back(cpu_ms() - a);
      }
      topo = std::move(child);
    }
    for (int s = 0; s <= steps; ++s) {
      a = cpu_ms();
      SubdivMesh m = subdivide(poly, SubdivScheme::kCatmullClark, s, SubdivOptions{});
      t_upto[s].push_back(cpu_ms() - a);
    }
    a = cpu_ms();
    {
      SubdivMesh m = run_ours(poly, level);
    }
    t_whole.push_back(cpu_ms() - a);
  }
  // Per rep r: A = T(2l + 1) - T(2l), B = T(2l + 2) - T(2l + 1) - refine, and their totals over the levels.
  const auto r_count = static_cast<std::size_t>(reps);
  std::vector<double> tot_a(r_count, 0.0), tot_b(r_count, 0.0), tot_r(r_count, 0.0), tot_sum(r_count, 0.0);
  std::printf("\nphases: varmesh, median of %d in-process reps (thread CPU ms)\n", reps);
  std::printf("  subdivide(%d steps, keep_last_edges=false), whole  %8.2f\n", steps, median(t_whole));
  std::printf("  make_subdiv_topology (validate + edge hash map)    %8.2f\n", median(t_topo));
  std::printf("  A = T(2l+1) - T(2l), B = T(2l+2) - T(2l+1) - refine, sum = T(2l+2) - T(2l), T(s) = subdivide(s steps):\n"
              "  differences taken within each rep, then the median over reps; \"<noise N\" where that median is\n"
              "  not above N, half the range of the per-rep differences (the reps disagree by more than the step)\n");
  std::printf("  %-6s %14s %14s %16s %14s\n", "level", "A (diag) step", "B (edge) step", "refine (edges)", "sum");
  for (int l = 0; l < level; ++l) {
    std::vector<double> da(r_count), db(r_count), dsum(r_count);
    for (std::size_t r = 0; r < r_count; ++r) {
      da[r] = t_upto[2 * l + 1][r] - t_upto[2 * l][r];
      db[r] = t_upto[2 * l + 2][r] - t_upto[2 * l + 1][r] - t_refine[l][r];
      dsum[r] = t_upto[2 * l + 2][r] - t_upto[2 * l][r];
      tot_a[r] += da[r];
      tot_b[r] += db[r];
      tot_r[r] += t_refine[l][r];
      tot_sum[r] += dsum[r];
    }
    std::printf("  %d->%d   %14s %14s %16.2f %14s\n", l, l + 1, step_cell(step_time(da)).c_str(),
                step_cell(step_time(db)).c_str(), median(t_refine[l]), step_cell(step_time(dsum)).c_str());
  }
  const StepTime sa = step_time(tot_a), sb = step_time(tot_b);
  std::vector<double> tot_ab(r_count);
  for (std::size_t r = 0; r < r_count; ++r) tot_ab[r] = tot_a[r] + tot_b[r];
  const StepTime sab = step_time(tot_ab);
  std::printf("  total  %14s %14s %16.2f %14s\n", step_cell(sa).c_str(), step_cell(sb).c_str(), median(tot_r),
              step_cell(step_time(tot_sum)).c_str());
  std::printf("  last refine without edges (what subdivide does)    %8.2f\n", median(t_last_refine_noedges));
  {
    double early = 0;
    for (int l = 0; l + 1 < level; ++l) early += median(t_refine[l]);
    const double last = median(t_last_refine_noedges), topo0 = median(t_topo), whole = median(t_whole);
    // The sum adds the position steps' median even when it is flagged: it is the only estimate there is.
    std::printf("  => subdivide = level-0 topology %.1f + refines with edges (levels 1..%d) %.1f + last refine %.1f + "
                "position steps %s (A %s, B %s) = %.1f (measured whole: %.1f)\n",
                topo0, level - 1, early, last, step_cell(sab).c_str(), step_cell(sa).c_str(), step_cell(sb).c_str(),
                topo0 + early + last + sab.ms, whole);
  }

  // Live bytes during the last refine (the peak): parent level with edges, child without, positions
  // (reserved at the final size), and the edge step's scratch (one dvec3 per parent vertex).
  SubdivTopology topo = make_subdiv_topology(poly);
  for (int l = 0; l + 1 < level; ++l) topo = refine_subdiv_topology(topo, true);
  const SubdivTopology child = refine_subdiv_topology(topo, false);
  const double faces = static_cast<double>(child.num_faces);
  const double pos = static_cast<double>(child.num_vertices) * sizeof(glm::dvec3);
  const double scratch = static_cast<double>(topo.num_vertices) * sizeof(glm::dvec3);
  auto arr = [&](const char* name, double bytes) { std::printf("    %-34s %10.1f MB %8.2f B/face\n", name, bytes / 1e6, bytes / faces); };
  std::printf("  modelled live bytes at the peak (last refine), per final face:\n");
  arr("positions (final, reserved)", pos);
  arr("edge-step scratch (parent vertices)", scratch);
  arr("parent face_verts", static_cast<double>(topo.face_verts.capacity() * 4));
  arr("parent face_edges", static_cast<double>(topo.face_edges.capacity() * 4));
  arr("parent edge_verts + edge_border", static_cast<double>(topo.edge_verts.capacity() * 4 + topo.edge_border.capacity()));
  arr("parent valence + vertex_border", static_cast<double>(topo.valence.capacity() * 2 + topo.vertex_border.capacity()));
  arr("child face_verts", static_cast<double>(child.face_verts.capacity() * 4));
  arr("child valence + vertex_border", static_cast<double>(child.valence.capacity() * 2 + child.vertex_border.capacity()));
  arr("total", pos + scratch + static_cast<double>(topo.memory_bytes() + child.memory_bytes()));
  arr("result kept (SubdivMesh::memory_bytes)", pos + static_cast<double>(child.memory_bytes()));
}

// ---------------------------------------------------------------- verification

// Maps varmesh's vertex numbering of level `level` to OpenSubdiv's, level by level (see the top comment).
// Returns false (with a message) when a correspondence fails.
bool map_vertices(const PolyMesh& poly, const Far::TopologyRefiner& ref, int level, std::vector<int>& vmap) {
  SubdivTopology t = make_subdiv_topology(poly);
  const std::size_t nv0 = poly.num_vertices();
  vmap.resize(nv0);
  for (std::size_t v = 0; v < nv0; ++v) vmap[v] = static_cast<int>(v);
  std::vector<int> fmap(t.num_faces);
  for (std::size_t f = 0; f < t.num_faces; ++f) fmap[f] = static_cast<int>(f);
  for (int l = 0; l < level; ++l) {
    const Far::TopologyLevel& L = ref.GetLevel(l);
    const Far::TopologyLevel& C = ref.GetLevel(l + 1);
    const std::size_t nv = t.num_vertices, nf = t.num_faces, ne = t.num_edges();
    std::vector<int> cv(nv + nf + ne, -1);
    for (std::size_t v = 0; v < nv; ++v) cv[v] = L.GetVertexChildVertex(vmap[v]);
    for (std::size_t f = 0; f < nf; ++f) cv[nv + f] = L.GetFaceChildVertex(fmap[f]);
    for (std::size_t e = 0; e < ne; ++e) {
      const int oe = L.FindEdge(vmap[t.edge_verts[2 * e]], vmap[t.edge_verts[2 * e + 1]]);
      if (oe < 0) {
        std::printf("  verify: edge %zu of level %d not found in OpenSubdiv\n", e, l);
        return false;
      }
      cv[nv + nf + e] = L.GetEdgeChildVertex(oe);
    }
    SubdivTopology child = refine_subdiv_topology(t, l + 1 < level);
    std::vector<int> cf(child.num_faces, -1);
    if (l + 1 < level) {
      for (std::size_t f = 0; f < nf; ++f) {
        const Far::ConstIndexArray kids = L.GetFaceChildFaces(fmap[f]);
        const Index off = t.offset(f), k = t.face_size(f);
        for (Index i = 0; i < k; ++i) {
          const int corner = cv[t.face_verts[off + i]];
          for (int j = 0; j < kids.size() && cf[off + i] < 0; ++j) {
            const Far::ConstIndexArray fv = C.GetFaceVertices(kids[j]);
            for (int q = 0; q < fv.size(); ++q)
              if (fv[q] == corner) cf[off + i] = kids[j];
          }
          if (cf[off + i] < 0) {
            std::printf("  verify: child face %u of level %d not matched\n", off + i, l + 1);
            return false;
          }
        }
      }
    }
    {
      std::size_t same_v = 0, same_f = 0, same_e = 0;
      for (std::size_t v = 0; v < nv; ++v) same_v += cv[v] == static_cast<int>(v);
      for (std::size_t f = 0; f < nf; ++f) same_f += cv[nv + f] == static_cast<int>(nv + f);
      for (std::size_t e = 0; e < ne; ++e) same_e += cv[nv + nf + e] == static_cast<int>(nv + nf + e);
      std::printf("  verify: level %d: same index in both: %zu of %zu vertex points, %zu of %zu face points, %zu of %zu "
                  "edge points\n",
                  l + 1, same_v, nv, same_f, nf, same_e, ne);
    }
    vmap.swap(cv);
    fmap.swap(cf);
    t = std::move(child);
  }
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  std::string mesh_path = "/work/shared/data/meshes/bunny_npm_1839v.obj";
  bool mesh_given = false;
  int level = 5, reps = 5, warm = 2, tor_u = 81, tor_v = 34;
  std::string only;
  bool do_phases = false, pair = true, osd_float = false, verify = true, torus = false;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto next = [&]() -> std::string {
      if (i + 1 >= argc) {
        std::fprintf(stderr, "%s needs a value\n", a.c_str());
        std::exit(1);
      }
      return argv[++i];
    };
    if (a == "--mesh") {
      mesh_path = next();
      mesh_given = true;
    } else if (a == "--level") {
      level = std::atoi(next().c_str());
    } else if (a == "--reps") {
      reps = std::max(1, std::atoi(next().c_str()));
    } else if (a == "--warm") {
      warm = std::clamp(std::atoi(next().c_str()), 0, 16);
    } else if (a == "--only") {
      only = next();
    } else if (a == "--phases") {
      do_phases = true;
    } else if (a == "--no-pair") {
      pair = false;
    } else if (a == "--osd-float") {
      osd_float = true;
    } else if (a == "--no-verify") {
      verify = false;
    } else if (a == "--torus") {
      torus = true;
      const std::string s = next();
      std::sscanf(s.c_str(), "%dx%d", &tor_u, &tor_v);
    } else {
      std::fprintf(stderr,
                   "usage: %s [--mesh FILE] [--level L] [--reps N] [--only varmesh|osd] [--phases] [--warm W] "
                   "[--no-pair] [--osd-float] [--no-verify] [--torus NUxNV]\n",
                   argv[0]);
      return 1;
    }
  }
  if (level < 1 || level > 8) {
    std::fprintf(stderr, "--level must be in 1..8\n");
    return 1;
  }
  if (!only.empty() && only != "varmesh" && only != "osd") {
    std::fprintf(stderr, "--only varmesh|osd\n");
    return 1;
  }

  // ---- input
  PolyMesh poly;
  std::string what;
  if (!torus && access(mesh_path.c_str(), R_OK) != 0) {
    if (mesh_given) {
      std::fprintf(stderr, "cannot read %s\n", mesh_path.c_str());
      return 1;
    }
    std::printf("note: %s missing, using the generated torus\n", mesh_path.c_str());
    torus = true;
  }
  if (torus) {
    poly = make_quad_torus(tor_u, tor_v);
    what = "quad torus " + std::to_string(tor_u) + " x " + std::to_string(tor_v);
  } else {
    const TriMesh tri = read_mesh(mesh_path);
    std::size_t leftovers = 0;
    const double a = now_ms();
    poly = pair ? pair_triangles(tri, &leftovers) : poly_from_triangles(tri);
    const double pair_ms = now_ms() - a;
    what = mesh_path.substr(mesh_path.find_last_of('/') + 1) + ": " + std::to_string(tri.num_faces()) +
           " triangles" +
           (pair ? " -> pair_triangles (" + std::to_string(leftovers) + " left unpaired, " +
                       std::to_string(pair_ms).substr(0, 5) + " ms)"
                 : " (not paired)");
  }
  std::size_t quads = 0, others = 0;
  for (std::size_t f = 0; f < poly.num_faces(); ++f) (poly.face_size(f) == 4 ? quads : others)++;
  std::printf("input: %s\n  %zu vertices, %zu faces (%zu quads, %zu other)\n", what.c_str(), poly.num_vertices(),
              poly.num_faces(), quads, others);
  std::printf("Catmull-Clark level %d (varmesh: %d binary steps), positions in double for both", level, 2 * level);
  std::printf("%s; OpenSubdiv %d.%d.%d\n", osd_float ? " (+ OpenSubdiv in float)" : "", OPENSUBDIV_VERSION_MAJOR,
              OPENSUBDIV_VERSION_MINOR, OPENSUBDIV_VERSION_PATCH);
  const OsdInput osd_in = osd_input(poly);

  // ---- forked, alternating repetitions
  const bool run_v = only.empty() || only == "varmesh", run_o = only.empty() || only == "osd";
  std::vector<RunReport> rv, ro, rf;
  auto ours_body = [&](RunReport& r) {
    const double w0 = now_ms(), c0 = cpu_ms();
    SubdivMesh m = run_ours(poly, level);
    r.cpu_ms = cpu_ms() - c0;
    r.wall_ms = now_ms() - w0;
    r.faces = m.topo.num_faces;
    r.vertices = m.positions.size();
    r.lib_bytes = m.memory_bytes();
    r.checksum = m.positions.back().x;
  };
  auto osd_run = [&](RunReport& r, auto real) {  // `real`: a double or a float, the primvar type
    const double w0 = now_ms(), c0 = cpu_ms();
    OsdResult<decltype(real)> o = run_osd<decltype(real)>(osd_in, poly, level);
    r.cpu_ms = cpu_ms() - c0;
    r.wall_ms = now_ms() - w0;
    r.t_create = o.t_create;
    r.t_refine = o.t_refine;
    r.t_primvar = o.t_primvar;
    r.faces = static_cast<std::uint64_t>(o.refiner->GetLevel(level).GetNumFaces());
    r.vertices = static_cast<std::uint64_t>(o.refiner->GetLevel(level).GetNumVertices());
    r.checksum = o.positions[0].p[0];
  };
  auto osd_body = [&](RunReport& r) { osd_run(r, 0.0); };
  auto osdf_body = [&](RunReport& r) { osd_run(r, 0.0f); };
  for (int rep = 0; rep < reps; ++rep) {
    if (run_v) rv.push_back(in_child(ours_body, warm));
    if (run_o) ro.push_back(in_child(osd_body, warm));
    if (run_o && osd_float) rf.push_back(in_child(osdf_body, warm));
  }
  std::printf("\n%d forked children per library (alternating), each: 1 cold run (fresh process: every page is\n"
              "faulted in; the memory is measured on it) + %d warm runs; medians over all children\n",
              reps, warm);
  std::printf("%-21s %9s | %9s %9s %9s | %9s %9s %9s | %9s %10s %9s\n", "library", "faces", "cold wall", "cold cpu",
              "Mfaces/s", "warm wall", "warm cpu", "Mfaces/s", "peak +MB", "bytes/face", "lib B/f");
  struct Row {
    double cold_fps = 0, warm_fps = 0, cold_cpu_fps = 0, warm_cpu_fps = 0, bpf = 0;
  };
  auto print = [&](const char* name, const std::vector<RunReport>& rs) -> Row {
    if (rs.empty()) return {};
    std::vector<double> w, c, ww, wc, pk, lb, cref, cpv, wref, wpv;
    for (const RunReport& r : rs) {
      w.push_back(r.wall_ms);
      c.push_back(r.cpu_ms);
      cref.push_back(r.t_refine);
      cpv.push_back(r.t_primvar);
      for (int k = 0; k < r.warm; ++k) {
        ww.push_back(r.warm_wall[k]);
        wc.push_back(r.warm_cpu[k]);
        wref.push_back(r.warm_refine[k]);
        wpv.push_back(r.warm_primvar[k]);
      }
      pk.push_back(static_cast<double>(r.peak_kb - r.base_kb) * 1024.0);
      lb.push_back(static_cast<double>(r.lib_bytes));
    }
    const double faces = static_cast<double>(rs[0].faces);
    Row row;
    row.cold_fps = faces / (median(w) * 1e-3);
    row.cold_cpu_fps = faces / (median(c) * 1e-3);
    row.warm_fps = ww.empty() ? 0 : faces / (median(ww) * 1e-3);
    row.warm_cpu_fps = wc.empty() ? 0 : faces / (median(wc) * 1e-3);
    if (ww.empty()) ww.push_back(0), wc.push_back(0);
    row.bpf = median(pk) / faces;
    char libb[32] = "-";
    if (rs[0].lib_bytes) std::snprintf(libb, sizeof libb, "%.1f", median(lb) / faces);
    std::printf("%-21s %9.0f | %9.1f %9.1f %9.2f | %9.1f %9.1f %9.2f | %9.1f %10.1f %9s\n", name, faces, median(w),
                median(c), row.cold_fps / 1e6, median(ww), median(wc), row.warm_fps / 1e6, median(pk) / 1e6, row.bpf,
                libb);
    std::printf("%-21s   wall ranges: cold [%.1f .. %.1f], warm [%.1f .. %.1f] ms; %llu vertices; peak reset %s, child "
                "maxrss at start %ld kB, RSS base %ld kB\n",
                "", *std::min_element(w.begin(), w.end()), *std::max_element(w.begin(), w.end()),
                ww.empty() ? 0.0 : *std::min_element(ww.begin(), ww.end()),
                ww.empty() ? 0.0 : *std::max_element(ww.begin(), ww.end()),
                static_cast<unsigned long long>(rs[0].vertices), rs[0].peak_reset ? "yes" : "NO", rs[0].start_maxrss_kb,
                rs[0].base_kb);
    if (rs[0].t_refine > 0) {
      std::vector<double> cr;
      for (const RunReport& r : rs) cr.push_back(r.t_create);
      std::printf("%-21s   parts (ms): Create %.1f; RefineUniform cold %.1f / warm %.1f; Interpolate cold %.1f / "
                  "warm %.1f\n",
                  "", median(cr), median(cref), median(wref), median(cpv), median(wpv));
    }
    return row;
  };
  const Row a = print("varmesh (double)", rv);
  const Row b = print("OpenSubdiv (double)", ro);
  const Row f = print("OpenSubdiv (float)", rf);
  auto ratios = [&](const char* name, const Row& o) {
    char warm_txt[64] = "warm n/a";
    if (o.warm_fps > 0 && a.warm_fps > 0)
      std::snprintf(warm_txt, sizeof warm_txt, "warm %.2fx (cpu %.2fx)", a.warm_fps / o.warm_fps,
                    a.warm_cpu_fps / o.warm_cpu_fps);
    std::printf("varmesh / %s: faces per second cold %.2fx (cpu %.2fx), %s; bytes per face %.2fx\n", name,
                a.cold_fps / o.cold_fps, a.cold_cpu_fps / o.cold_cpu_fps, warm_txt, a.bpf / o.bpf);
  };
  if (!rv.empty() && !ro.empty()) {
    ratios("OpenSubdiv (double)", b);
    if (!rf.empty()) ratios("OpenSubdiv (float)", f);
    std::printf("goal: >= 1.5x OpenSubdiv's faces per second, <= 100 bytes per face (varmesh: %.1f)\n", a.bpf);
  }

  if (do_phases && run_v) phases(poly, level, reps);

  // ---- verification
  if (verify && run_v && run_o) {
    const SubdivMesh m = run_ours(poly, level);
    const OsdResult<double> o = run_osd<double>(osd_in, poly, level);
    const Far::TopologyLevel& last = o.refiner->GetLevel(level);
    std::printf("\nverify: vertices %zu (varmesh) / %d (OpenSubdiv), faces %zu / %d\n", m.positions.size(),
                last.GetNumVertices(), m.topo.num_faces, last.GetNumFaces());
    glm::dvec3 lo(1e300), hi(-1e300);
    for (const glm::dvec3& p : poly.positions) {
      lo = glm::min(lo, p);
      hi = glm::max(hi, p);
    }
    const double diag = glm::length(hi - lo);
    std::vector<int> vmap;
    const double t0 = now_ms();
    if (static_cast<int>(m.positions.size()) == last.GetNumVertices() && map_vertices(poly, *o.refiner, level, vmap)) {
      double err = 0;
      std::size_t identical_index = 0;
      for (std::size_t v = 0; v < vmap.size(); ++v) {
        const double* q = o.positions[vmap[v]].p;
        err = std::max(err, glm::length(m.positions[v] - glm::dvec3(q[0], q[1], q[2])));
        identical_index += vmap[v] == static_cast<int>(v);
      }
      std::printf("verify: vertex-for-vertex (numbering mapped level by level, %.0f ms): max |varmesh - osd| / bbox "
                  "diagonal = %.3g (%s); %zu of %zu vertices have the same index in both\n",
                  now_ms() - t0, err / diag, err / diag <= 1e-12 ? "agree" : "DISAGREE", identical_index,
                  vmap.size());
    } else {
      std::printf("verify: mapping FAILED\n");
    }
  }
  return 0;
}
