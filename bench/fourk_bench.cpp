// Semi-regular 4-k benchmark for BENCHMARKS.md (issue 4, section 7): build and extraction rates for a mesh
// refined to >= 1M faces, bytes per face, incremental update() against extraction from scratch.
//
//  1. build: match_dual_faces, build_semiregular_fourk (matching included), FourKMesh::to_mt (default
//     options, then without the geometry check), build_semiregular_mt end to end; medians of --reps runs;
//     Mt::memory_bytes() and FourKMesh::memory_bytes() per finest face, with the Mt's bytes split by array
//     (Mt::memory_breakdown(), checked against memory_bytes()). Also simplify4k on
//     the cow (--cow FILE, "none" to skip).
//  2. extraction: MtFront + extract() with Criterion::object_error at thresholds giving about 10k, 100k,
//     300k and 1M faces (found by bisection before timing; a target below the base mesh is reported as
//     unreachable) and at threshold 0 (the finest mesh); then MtFront::to_mesh().
//  3. incremental: a --frames K camera orbit (one full turn, camera framing the bounding sphere from
//     (sin a, 0.35, cos a), 45 deg, 16:9, +y up) with any_of(outside_frustum, back_facing(eye),
//     screen_error(camera, 1080 px, tau)), tau found by bisection so that 8 views average --orbit-faces
//     faces. update() of one front (frame i starts from frame i-1) against extract() from scratch (the
//     same MtFront object, which extract() resets: reset is timed), each run over whole orbits on its own
//     front; per frame the two face sets are compared (count and an order-independent hash).
//
// Times: CPU time of the process (CLOCK_PROCESS_CPUTIME_ID; everything timed is single-threaded) and wall time.
//
// usage: varmesh_fourk_bench [--mesh FILE] [--levels L] [--reps N] [--frames K] [--orbit-faces F]
//                            [--cow FILE|none]
#include <time.h>

#include <algorithm>
#include <chrono>

#include "bench_timing.hpp"
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <fstream>
#include <string>
#include <vector>

#include "fourk/fourk_mesh.hpp"
#include "fourk/semiregular.hpp"
#include "fourk/simplify4k.hpp"
#include "multitri/camera.hpp"
#include "multitri/mesh_io.hpp"
#include "multitri/mt.hpp"
#include "multitri/mt_front.hpp"
#include "multitri/mt_metrics.hpp"
#include "multitri/query.hpp"

using namespace varmesh;
using Clock = varmesh::bench::Clock;

namespace {

using bench::Lap;
using bench::Laps;
using bench::median;
using bench::seconds_since;
using bench::Stopwatch;
using bench::process_cpu_seconds;

std::string loadavg() {
  std::ifstream in("/proc/loadavg");
  std::string a, b, c;
  in >> a >> b >> c;
  return a + " " + b + " " + c;
}

struct Options {
  std::string mesh = "/work/shared/data/meshes/bun_zipper_35947v.obj";
  std::string cow = "/work/shared/data/meshes/cow_cgal_2904v.off";
  int levels = 4;
  int reps = 3;
  int frames = 120;
  double orbit_faces = 100000.0;
};

Options parse(int argc, char** argv) {
  Options o;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto val = [&]() -> std::string {
      if (i + 1 >= argc) {
        std::fprintf(stderr, "missing value after %s\n", a.c_str());
        std::exit(2);
      }
      return argv[++i];
    };
    if (a == "--mesh") o.mesh = val();
    else if (a == "--cow") o.cow = val();
    else if (a == "--levels") o.levels = std::atoi(val().c_str());
    else if (a == "--reps") o.reps = std::max(1, std::atoi(val().c_str()));
    else if (a == "--frames") o.frames = std::max(2, std::atoi(val().c_str()));
    else if (a == "--orbit-faces") o.orbit_faces = std::atof(val().c_str());
    else {
      std::fprintf(stderr,
                   "usage: %s [--mesh FILE] [--levels L] [--reps N] [--frames K] [--orbit-faces F] [--cow FILE|none]\n",
                   argv[0]);
      std::exit(2);
    }
  }
  return o;
}

// ---------------------------------------------------------------- memory breakdown of an Mt

struct MtBreakdown {
  struct Item {
    const char* name;
    std::size_t bytes;
  };
  std::vector<Item> items;
  std::size_t total = 0;
};

MtBreakdown mt_breakdown(const Mt& mt) {
  const std::size_t nodes = mt.num_nodes();
  std::size_t pre = 0, par = 0, ch = 0;
  for (NodeId n = 0; n < nodes; ++n) {
    pre += mt.pre_image(n).size();
    par += mt.parents(n).size();
    ch += mt.children(n).size();
  }
  MtBreakdown b;
  for (const auto& it : mt.memory_breakdown()) b.items.push_back({it.name, it.bytes});
  for (const auto& it : b.items) b.total += it.bytes;
  std::printf("  Mt: %zu nodes, %zu faces, %zu vertices; pre-image items %.2f / node, parents %.2f / node, "
              "children %.2f / node (parents and children derived, not stored)\n",
              nodes, mt.num_faces(), mt.num_vertices(), double(pre) / double(nodes), double(par) / double(nodes),
              double(ch) / double(nodes));
  return b;
}

// ---------------------------------------------------------------- 1. build

void print_lap_row(const char* what, const Laps& l, double faces) {
  const Lap m = l.med();
  std::printf("| %s | %.3f | %.3f | %.2f |\n", what, m.cpu, m.wall, faces / m.cpu * 1e-6);
}

struct Built {
  Mt mt;
  std::size_t finest = 0;
};

Built bench_build(const Options& o, const TriMesh& base) {
  std::printf("\n== 1. build: %s, %zu faces, %d levels, %d reps ==\n", o.mesh.c_str(), base.num_faces(), o.levels,
              o.reps);
  Laps t_match, t_fourk, t_tomt, t_tomt_nocheck, t_mt;
  Built out;
  std::size_t fk_bytes = 0, fk_faces = 0, fk_current = 0, fk_mods = 0, fk_vertices = 0;
  DualMatching dm;
  SemiRegularInfo info;
  for (int r = 0; r < o.reps; ++r) {
    {
      const Stopwatch sw;
      dm = match_dual_faces(base);
      t_match.add(sw.lap());
    }
    FourKMesh fk;
    {
      const Stopwatch sw;
      fk = build_semiregular_fourk(base, o.levels, {}, r == 0 ? &info : nullptr);
      t_fourk.add(sw.lap());
    }
    fk_bytes = fk.memory_bytes();
    fk_faces = fk.num_faces();
    fk_current = fk.num_current_faces();
    fk_mods = fk.num_modifications();
    fk_vertices = fk.num_vertices();
    {
      const Stopwatch sw;
      out.mt = fk.to_mt();
      t_tomt.add(sw.lap());
    }
    {
      MtBuilder::Options bo;
      bo.check_geometry = false;
      const Stopwatch sw;
      Mt m2 = fk.to_mt(bo);
      t_tomt_nocheck.add(sw.lap());
    }
  }
  out.finest = fk_current;
  for (int r = 0; r < o.reps; ++r) {
    const Stopwatch sw;
    Mt m3 = build_semiregular_mt(base, o.levels);
    t_mt.add(sw.lap());
  }
  const double F = static_cast<double>(fk_current);
  std::printf("  matching: %zu pairs, %zu leftovers, %zu border faces, greedy %zu, augmentations %zu\n", dm.num_pairs,
              dm.num_leftovers, dm.num_border_faces, dm.graph.greedy_pairs, dm.graph.augmentations);
  std::printf("  faces per level:");
  for (auto f : info.faces_per_level) std::printf(" %zu", f);
  std::printf("\n  FourKMesh: %zu faces ever created, %zu current (finest), %zu modifications, %zu vertices\n",
              fk_faces, fk_current, fk_mods, fk_vertices);
  std::printf("\n| phase | CPU s (median) | wall s (median) | M finest faces / s (CPU) |\n|---|---|---|---|\n");
  print_lap_row("match_dual_faces", t_match, F);
  print_lap_row("build_semiregular_fourk (matching included)", t_fourk, F);
  print_lap_row("FourKMesh::to_mt (default: saturate + check_geometry)", t_tomt, F);
  print_lap_row("FourKMesh::to_mt (check_geometry = false)", t_tomt_nocheck, F);
  print_lap_row("build_semiregular_mt (end to end)", t_mt, F);
  std::printf("  (per-rep CPU s: to_mt");
  for (double c : t_tomt.cpu) std::printf(" %.3f", c);
  std::printf("; fourk");
  for (double c : t_fourk.cpu) std::printf(" %.3f", c);
  std::printf(")\n");

  const MtMetrics mm = compute_metrics(out.mt);
  std::printf("\n  Mt metrics: nodes %zu, faces %zu, coarsest %zu, finest %zu, depth %zu, growth %.3f\n", mm.nodes,
              mm.faces, mm.coarsest_faces, mm.finest_faces, mm.depth, mm.growth_rate);
  std::printf("  Mt::memory_bytes() = %zu (%.1f MB) = %.2f B / finest face\n", mm.memory_bytes, static_cast<double>(mm.memory_bytes) / 1e6,
              mm.bytes_per_face);
  std::printf("  FourKMesh::memory_bytes() = %zu (%.1f MB) = %.2f B / finest face (%.2f B / face ever created)\n",
              fk_bytes, static_cast<double>(fk_bytes) / 1e6, double(fk_bytes) / F, double(fk_bytes) / double(fk_faces));
  const MtBreakdown b = mt_breakdown(out.mt);
  std::printf("\n| Mt array | bytes | B / finest face |\n|---|---|---|\n");
  for (const auto& it : b.items)
    std::printf("| %s | %zu | %.2f |\n", it.name, it.bytes, double(it.bytes) / double(mm.finest_faces));
  std::printf("| total (sum of the items) | %zu | %.2f |\n", b.total, double(b.total) / double(mm.finest_faces));
  std::printf("  sum of the items %s Mt::memory_bytes() (%zu vs %zu)\n",
              b.total == mm.memory_bytes ? "==" : "!=", b.total, mm.memory_bytes);
  return out;
}

void bench_cow(const Options& o) {
  if (o.cow == "none") return;
  std::printf("\n== 1b. simplify4k: %s ==\n", o.cow.c_str());
  TriMesh cow;
  try {
    cow = read_mesh(o.cow);
  } catch (const std::exception& e) {
    std::printf("  cannot read: %s\n", e.what());
    return;
  }
  Laps t;
  Simplify4kResult res;
  for (int r = 0; r < o.reps; ++r) {
    const Stopwatch sw;
    res = simplify4k(cow);
    t.add(sw.lap());
  }
  const MtMetrics mm = compute_metrics(res.mt);
  std::printf("  input %zu faces; %zu levels, base %zu faces; %zu split nodes, %zu swap nodes; depth %zu\n",
              cow.num_faces(), res.num_levels(), mm.coarsest_faces, res.num_split_nodes, res.num_swap_nodes,
              mm.depth);
  std::printf("| simplify4k | CPU s %.3f | wall s %.3f | %.3f M input faces / s (CPU) | Mt %.1f B / finest face "
              "(%zu B) |\n",
              t.med().cpu, t.med().wall, double(cow.num_faces()) / t.med().cpu * 1e-6, mm.bytes_per_face,
              mm.memory_bytes);
}

// ---------------------------------------------------------------- 2. extraction

float max_node_error(const Mt& mt) {
  float m = 0.0f;
  for (NodeId n = 0; n < mt.num_nodes(); ++n) m = std::max(m, mt.bound(n).error);
  return m;
}

std::size_t faces_at(MtFront& f, float t) {
  Query q;
  q.criterion = Criterion::object_error(t);
  extract(f, q);
  return f.num_faces();
}

void bench_extract(const Options& o, const Mt& mt, std::size_t finest) {
  std::printf("\n== 2. extraction (object_error), %d reps ==\n", o.reps);
  Laps t_ctor;
  for (int r = 0; r < o.reps; ++r) {
    const Stopwatch sw;
    MtFront f(mt);
    t_ctor.add(sw.lap());
  }
  std::printf("  MtFront construction: %.2f ms CPU (%.2f wall)\n", 1e3 * t_ctor.med().cpu, 1e3 * t_ctor.med().wall);
  MtFront f(mt);
  const std::size_t base_faces = mt.image_size(0);
  const float emax = max_node_error(mt);
  std::printf("  base faces %zu, largest node error %.6g\n", base_faces, emax);
  std::printf("\n| target | threshold | faces | extract CPU ms | wall ms | Mtri/s (CPU) | nodes applied | "
              "to_mesh CPU ms | wall ms |\n|---|---|---|---|---|---|---|---|---|\n");
  const double targets[] = {1e4, 1e5, 3e5, 1e6, 0.0};
  for (double target : targets) {
    float thr = 0.0f;
    if (target > 0.0) {
      if (target <= static_cast<double>(base_faces)) {
        std::printf("| %.0fk | – | unreachable: the coarsest front is the base mesh (%zu faces) | | | | | | |\n",
                    target / 1e3, base_faces);
        continue;
      }
      if (target >= static_cast<double>(finest)) {
        std::printf("| %.0fk | – | unreachable: the finest mesh has %zu faces (row \"finest\") | | | | | | |\n",
                    target / 1e3, finest);
        continue;
      }
      float lo = emax * 1e-6f, hi = emax * 1.01f;  // faces(lo) > target >= faces(hi)
      for (int it = 0; it < 40; ++it) {
        const float mid = std::sqrt(lo * hi);
        if (static_cast<double>(faces_at(f, mid)) > target) lo = mid; else hi = mid;
      }
      const double flo = static_cast<double>(faces_at(f, lo)), fhi = static_cast<double>(faces_at(f, hi));
      thr = std::abs(flo - target) < std::abs(fhi - target) ? lo : hi;
    }
    Query q;
    q.criterion = Criterion::object_error(thr);
    Laps te, tm;
    std::size_t faces = 0, applied = 0;
    for (int r = 0; r < o.reps; ++r) {
      {
        const Stopwatch sw;
        extract(f, q);
        te.add(sw.lap());
      }
      faces = f.num_faces();
      applied = f.num_applied();
      const Stopwatch sw;
      TriMesh m = f.to_mesh();
      tm.add(sw.lap());
      if (m.num_faces() != faces) std::printf("  !! to_mesh gave %zu faces, front %zu\n", m.num_faces(), faces);
    }
    if (target == 0.0) f.validate();
    std::printf("| %s | %.6g | %zu | %.2f | %.2f | %.2f | %zu | %.2f | %.2f |\n",
                target > 0.0 ? (std::to_string(static_cast<long>(target / 1e3)) + "k").c_str() : "finest", thr, faces,
                1e3 * te.med().cpu, 1e3 * te.med().wall, static_cast<double>(faces) / te.med().cpu * 1e-6, applied,
                1e3 * tm.med().cpu, 1e3 * tm.med().wall);
  }
}

// ---------------------------------------------------------------- 3. incremental

Query orbit_query(const Camera& cam, float pixels) {
  Query q;
  q.criterion = Criterion::any_of({Criterion::outside_frustum(cam.frustum()), Criterion::back_facing(cam.eye),
                                   Criterion::screen_error(cam, 1080.0f, pixels)});
  return q;
}

std::uint64_t mix(std::uint64_t x) {
  x += 0x9e3779b97f4a7c15ull;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ull;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebull;
  return x ^ (x >> 31);
}

std::uint64_t face_hash(const MtFront& f) {
  std::uint64_t h = 0;
  for (FaceId x : f.faces()) h += mix(x);
  return h;
}

void bench_orbit(const Options& o, const Mt& mt, const TriMesh& base) {
  const int K = o.frames;
  std::printf("\n== 3. incremental: %d-frame orbit (%.1f deg / frame), %d orbits per method ==\n", K, 360.0 / K,
              o.reps);
  std::vector<glm::vec3> used;
  {
    std::vector<std::uint8_t> ref(base.num_vertices(), 0);
    for (Index v : base.indices) ref[v] = 1;
    for (std::size_t v = 0; v < ref.size(); ++v)
      if (ref[v]) used.push_back(base.positions[v]);
  }
  const Sphere s = bounding_sphere(used.data(), used.size());
  std::vector<Camera> cams;
  for (int i = 0; i <= K; ++i) {
    const float a = 6.2831853f * static_cast<float>(i) / static_cast<float>(K);
    cams.push_back(frame_sphere(s.center, s.radius, glm::vec3(std::sin(a), 0.35f, std::cos(a)), 45.0f, 16.0f / 9.0f,
                                glm::vec3(0.0f, 1.0f, 0.0f)));
  }
  MtFront a(mt), b(mt);
  float lo = 1e-3f, hi = 1e3f;
  for (int it = 0; it < 26; ++it) {
    const float mid = std::sqrt(lo * hi);
    double sum = 0.0;
    for (int i = 0; i < 8; ++i) {
      extract(a, orbit_query(cams[static_cast<std::size_t>(i * K / 8)], mid));
      sum += static_cast<double>(a.num_faces());
    }
    if (sum / 8.0 > o.orbit_faces) lo = mid; else hi = mid;
  }
  const float tau = hi;
  std::vector<Query> qs;
  for (const Camera& c : cams) qs.push_back(orbit_query(c, tau));

  Laps t_up, t_ex, t_co;
  std::vector<double> faces, changed, eval_up, eval_ex, eval_co, reused_co;
  std::vector<std::size_t> n_up(K + 1), n_ex(K + 1), n_co(K + 1);
  std::vector<std::uint64_t> h_up(K + 1), h_ex(K + 1), h_co(K + 1);
  std::size_t count_diff = 0, set_diff = 0, finer = 0, coarser = 0, max_delta = 0, rep_diff = 0, coherent_diff = 0;
  MtFront cf(mt);
  QueryCoherence coherence;
  for (int rep = 0; rep < o.reps; ++rep) {
    extract(a, qs[0]);  // the update front starts at frame 0, untimed
    for (int i = 1; i <= K; ++i) {
      const Stopwatch sw;
      const QueryStats st = update(a, qs[static_cast<std::size_t>(i)]);
      t_up.add(sw.lap());
      const auto u = static_cast<std::size_t>(i);
      const std::uint64_t h = face_hash(a);
      if (rep > 0 && (n_up[u] != a.num_faces() || h_up[u] != h)) ++rep_diff;
      n_up[u] = a.num_faces();
      h_up[u] = h;
      if (rep == 0) {
        changed.push_back(static_cast<double>(st.coarsened + st.refined));
        eval_up.push_back(static_cast<double>(st.evaluated));
      }
    }
    // update() with frame-to-frame coherence on a third front (the coherence memory persists across reps,
    // as it would in an application; its first frame of the first rep evaluates everything).
    extract(cf, qs[0]);
    for (int i = 1; i <= K; ++i) {
      const Stopwatch sw;
      const QueryStats st = update(cf, qs[static_cast<std::size_t>(i)], coherence);
      t_co.add(sw.lap());
      const auto u = static_cast<std::size_t>(i);
      n_co[u] = cf.num_faces();
      h_co[u] = face_hash(cf);
      if (rep == 0) {
        eval_co.push_back(static_cast<double>(st.evaluated));
        reused_co.push_back(static_cast<double>(st.reused));
      }
    }
    for (int i = 1; i <= K; ++i) {
      const Stopwatch sw;
      const QueryStats st = extract(b, qs[static_cast<std::size_t>(i)]);
      t_ex.add(sw.lap());
      if (rep == 0) eval_ex.push_back(static_cast<double>(st.evaluated));
      const auto u = static_cast<std::size_t>(i);
      n_ex[u] = b.num_faces();
      h_ex[u] = face_hash(b);
      if (rep == 0) faces.push_back(static_cast<double>(b.num_faces()));
    }
    for (int i = 1; i <= K; ++i) {
      const auto u = static_cast<std::size_t>(i);
      if (n_up[u] != n_ex[u]) {
        ++count_diff;
        if (n_up[u] > n_ex[u]) ++finer; else ++coarser;
        max_delta = std::max(max_delta, n_up[u] > n_ex[u] ? n_up[u] - n_ex[u] : n_ex[u] - n_up[u]);
      }
      if (h_up[u] != h_ex[u]) ++set_diff;
      if (n_co[u] != n_ex[u] || h_co[u] != h_ex[u]) ++coherent_diff;
    }
  }
  a.validate();
  // Where update()'s time goes: it lists the front's refine candidates (each node once, from MtFront's
  // candidate set) and its undoable nodes, and asks the criterion about each.
  std::size_t listed = 0, coarsen_listed = 0;
  std::vector<Index> cand;
  a.for_each_refine_candidate([&](Index e) {
    ++listed;
    cand.push_back(e);
  });
  a.for_each_coarsen_candidate([&](Index) { ++coarsen_listed; });
  std::sort(cand.begin(), cand.end());
  const std::size_t distinct = static_cast<std::size_t>(std::unique(cand.begin(), cand.end()) - cand.begin());
  cand.resize(distinct);
  Laps t_eval;
  std::size_t wanted = 0;
  for (int r = 0; r < 5; ++r) {
    wanted = 0;
    const Stopwatch sw;
    a.for_each_refine_candidate([&](Index e) { wanted += qs[static_cast<std::size_t>(K)].wants(a.element_bound(e)); });
    a.for_each_coarsen_candidate([&](Index e) { wanted += qs[static_cast<std::size_t>(K)].wants(a.element_bound(e)); });
    t_eval.add(sw.lap());
  }
  std::printf("  last frame's front: %zu faces; refine candidates listed %zu (%zu distinct nodes), coarsen candidates "
              "%zu; asking the criterion about all listed candidates once: %.3f ms CPU (median of 5)\n",
              a.num_faces(), listed, distinct, coarsen_listed, 1e3 * t_eval.med().cpu);
  const double fmin = *std::min_element(faces.begin(), faces.end());
  const double fmax = *std::max_element(faces.begin(), faces.end());
  std::printf("  bounding sphere of the referenced vertices: centre (%.4g, %.4g, %.4g), radius %.4g\n", s.center.x,
              s.center.y, s.center.z, s.radius);
  std::printf("  tau = %.4g px on a 1080-line viewport; faces per frame: median %.0f, min %.0f, max %.0f; update() "
              "coarsens + refines %.0f nodes per frame (median; mean %.1f)\n",
              tau, median(faces), fmin, fmax, median(changed),
              [&] {
                double s2 = 0.0;
                for (double c : changed) s2 += c;
                return s2 / static_cast<double>(changed.size());
              }());
  std::printf("  criterion evaluations per frame (median): update() %.0f, extract() %.0f\n", median(eval_up),
              median(eval_ex));
  std::printf("\n| method | CPU ms / frame median | CPU p95 | wall ms / frame median | wall p95 |\n|---|---|---|---|---|\n");
  std::printf("| update() (incremental) | %.3f | %.3f | %.3f | %.3f |\n", 1e3 * t_up.med().cpu, 1e3 * t_up.p95().cpu,
              1e3 * t_up.med().wall, 1e3 * t_up.p95().wall);
  std::printf("| update() with QueryCoherence | %.3f | %.3f | %.3f | %.3f |\n", 1e3 * t_co.med().cpu,
              1e3 * t_co.p95().cpu, 1e3 * t_co.med().wall, 1e3 * t_co.p95().wall);
  std::printf("| extract() from scratch | %.3f | %.3f | %.3f | %.3f |\n", 1e3 * t_ex.med().cpu, 1e3 * t_ex.p95().cpu,
              1e3 * t_ex.med().wall, 1e3 * t_ex.p95().wall);
  std::printf("  extract / coherent update (CPU medians) = %.2fx; coherent update: %.0f evaluations and %.0f reused "
              "answers per frame (median); frames differing from extract(): %zu of %d\n",
              t_ex.med().cpu / t_co.med().cpu, median(eval_co), median(reused_co), coherent_diff,
              K * o.reps);
  std::printf("  extract / update (CPU medians) = %.2fx (wall %.2fx)\n", t_ex.med().cpu / t_up.med().cpu,
              t_ex.med().wall / t_up.med().wall);
  std::printf("  frames compared: %d; face count differs in %zu (update finer %zu, coarser %zu, max |delta| %zu); "
              "face set (hash) differs in %zu; update orbit not reproducible across reps in %zu frames\n",
              K * o.reps, count_diff, finer, coarser, max_delta, set_diff, rep_diff);
}

}  // namespace

int main(int argc, char** argv) {
  const Options o = parse(argc, argv);
  std::printf("varmesh_fourk_bench: mesh %s, levels %d, reps %d, frames %d, orbit faces %.0f; load %s\n",
              o.mesh.c_str(), o.levels, o.reps, o.frames, o.orbit_faces, loadavg().c_str());
  try {
    const Stopwatch sw;
    const TriMesh base = read_mesh(o.mesh);
    const Lap l = sw.lap();
    std::printf("  read_mesh: %zu vertices, %zu faces, %.3f s wall\n", base.num_vertices(), base.num_faces(), l.wall);
    std::fflush(stdout);
    const Built built = bench_build(o, base);
    std::fflush(stdout);
    bench_cow(o);
    std::fflush(stdout);
    bench_extract(o, built.mt, built.finest);
    std::fflush(stdout);
    bench_orbit(o, built.mt, base);
  } catch (const std::exception& e) {
    std::printf("error: %s\n", e.what());
    return 1;
  }
  std::printf("\nload at the end: %s\n", loadavg().c_str());
  return 0;
}
