// Long randomized soak of the pm correctness oracle (sr_oracle.hpp), far longer than CI runs it, to find
// rare failures. Not a ctest test: built with -DVARMESH_BUILD_SOAK=ON and run by hand.
//
//   pm_soak [--seconds S] [--case-seconds C] [--seed N] [--fixtures] [--only-option NAME]
//           [--only-scheme NAME] [--full-every K] [MESH...]
//
// For each mesh (the generated fixtures of the tests with --fixtures, then the files given) and each set of
// hierarchy options (default, two parallel parts, a face target with and without the Lindstrom-Turk
// finish, Lindstrom-Turk costs, colours where the mesh has them, locked non-manifold vertices, an error
// limit), it builds the hierarchy, checks VertexHierarchy::validate() and that encode(decode(encode(h)))
// gives the same bytes, then under each scheme:
// - refine_all gives the input (through leaf_to_input, face_to_input) and coarsen_all the base mesh;
// - phases of CheckedWalk (mostly refine, mostly coarsen, even) with every operation checked locally and
//   the whole mesh against the model, the dual-piece oracle and SrMesh::validate() every few requests;
// - query phases (extract or update with random cameras, error thresholds and triangle budgets), each
//   answer checked against the dual-piece oracle (manifold, oriented), validate(), the fixpoint property
//   or the budget, and under Hoppe-97 and Xia-Varshney update() against extract();
// - refine_all and coarsen_all again from the selective state.
// One line per (mesh, option, scheme) with the requests run; on the first failure of a case its seed and
// request, and the case stops. The exit status is the number of failed cases (at most 255).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <random>
#include <string>
#include <vector>

#include "multitri/camera.hpp"
#include "multitri/errors.hpp"
#include "multitri/mesh_io.hpp"
#include "multitri/query.hpp"
#include "pm/hierarchy_io.hpp"
#include "pm/qem_analysis.hpp"
#include "pm/sr_mesh.hpp"
#include "pm_fixtures.hpp"
#include "sr_oracle.hpp"

namespace varmesh {
namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

struct NamedMesh {
  std::string name;
  TriMesh mesh;
};

struct NamedOptions {
  std::string name;
  QemOptions options;
};

// The option sets tried. Those that cannot change anything for a mesh (colours on a mesh without
// any) are left out.
std::vector<NamedOptions> option_sets(const TriMesh& m) {
  std::vector<NamedOptions> out;
  out.push_back({"default", {}});
  QemOptions o;
  o.threads = 2;
  o.min_part_faces = 64;  // so that small meshes are cut too
  out.push_back({"threads2", o});
  o = {};
  o.target_faces = std::max<std::size_t>(m.num_faces() / 20, 8);
  out.push_back({"target", o});
  o.lt_finish = 0.0;
  out.push_back({"target-lt0", o});
  o = {};
  o.cost = CollapseCost::kLindstromTurk;
  out.push_back({"lindstrom-turk", o});
  if (m.has_colors()) {
    o = {};
    o.use_colors = true;
    out.push_back({"colors", o});
  }
  o = {};
  o.non_manifold = NonManifoldPolicy::kLock;
  out.push_back({"lock", o});
  o = {};
  o.max_error = 0.005 * static_cast<double>(m.bounds().diagonal());
  out.push_back({"max-error", o});
  return out;
}

// The generated meshes of the pm tests, and a coloured icosphere (the only coloured input here).
std::vector<NamedMesh> fixtures() {
  using namespace testing;
  std::vector<NamedMesh> out;
  out.push_back({"icosphere3", make_icosphere(3)});
  out.push_back({"grid20x14", make_grid(20, 14)});
  out.push_back({"torus24x12", make_torus(24, 12)});
  out.push_back({"icosphere1+grid5", concat(make_icosphere(1), make_grid(5, 5), {3, 0, 0})});
  TriMesh c = make_icosphere(3);
  for (const glm::vec3& p : c.positions) c.colors.push_back(0.5f + 0.5f * glm::vec3(std::sin(5.0f * p.x), p.y, std::cos(3.0f * p.z)));
  out.push_back({"icosphere3-colored", c});
  TriMesh bumpy = make_icosphere(4);
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> radius(0.7f, 1.3f);
  for (glm::vec3& p : bumpy.positions) p *= radius(rng);
  out.push_back({"bumpy-icosphere4", bumpy});
  return out;
}

bool is_fixpoint(const SrMesh& sr, const Query& q) {
  const VertexHierarchy& h = sr.hierarchy();
  for (Index v = static_cast<Index>(h.num_leaves()); v < h.num_nodes(); ++v)
    if (sr.is_active(v) && q.wants(h.bound(v))) return false;
  return true;
}

struct Totals {
  std::size_t requests = 0, ops = 0, queries = 0, full_checks = 0, oracle_checks = 0, presplits = 0, postponed = 0;
};

class Soak {
 public:
  Soak(const VertexHierarchy& h, RefinementScheme s, const TriMesh& input, std::uint32_t seed, std::size_t full_every)
      : h_(h), input_(input), sr_(h, s), rng_(seed), t_(testing::subtrees_of(h)), full_every_(full_every) {
    Box3 box;
    for (std::size_t l = 0; l < h.num_leaves(); ++l) box.add(h.position(static_cast<Index>(l)));
    center_ = box.center();
    diag_ = std::max(box.diagonal(), 1e-6f);
  }

  // Runs until `deadline`; "" or the first failure.
  std::string run(Clock::time_point deadline) {
    std::string p = full_round_trip("at the start");
    for (std::size_t phase = 0; p.empty() && Clock::now() < deadline; ++phase) {
      const std::uint32_t kind = std::uniform_int_distribution<std::uint32_t>(0, 9)(rng_);
      if (kind < 2) p = query_phase(phase);
      else if (kind == 9) p = full_round_trip("phase " + std::to_string(phase));
      else p = walk_phase(phase, kind);
    }
    if (p.empty()) p = full_round_trip("at the end");
    totals_.presplits = sr_.stats().presplits, totals_.postponed = sr_.stats().postponed_ecols;
    return p;
  }
  const Totals& totals() const { return totals_; }

 private:
  std::string walk_phase(std::size_t phase, std::uint32_t kind) {
    testing::WalkOptions o;
    // Biased phases: mostly refine, mostly coarsen, even.
    o.split_bias = kind < 5 ? 0.8 : kind < 7 ? 0.2 : 0.5;
    o.ops = std::uniform_int_distribution<std::size_t>(50, 3000)(rng_);
    o.seed = static_cast<std::uint32_t>(rng_());
    o.full_every = full_every_, o.oracle_every = 10 * full_every_, o.validate_every = 10 * full_every_;
    o.list_pick = 0.5;
    const testing::WalkResult r = testing::run_checked_walk(sr_, o, &t_);
    totals_.requests += r.steps, totals_.ops += r.ops(), totals_.full_checks += r.full_checks, totals_.oracle_checks += r.oracle_checks;
    if (!r.ok) return "walk phase " + std::to_string(phase) + " (walk seed " + std::to_string(o.seed) + ", bias " + std::to_string(o.split_bias) + "): " + r.failure;
    return "";
  }

  Camera random_camera() {
    std::uniform_real_distribution<float> u(-1.0f, 1.0f), dist(0.3f, 3.0f);
    glm::vec3 d{u(rng_), u(rng_), u(rng_)};
    if (glm::length(d) < 1e-3f) d = {1, 0, 0};
    Camera c;
    c.eye = center_ + dist(rng_) * diag_ * glm::normalize(d);
    c.target = center_ + 0.2f * diag_ * glm::vec3(u(rng_), u(rng_), u(rng_));
    c.fov_y_deg = 20.0f + 50.0f * (0.5f + 0.5f * u(rng_));
    c.z_near = 1e-3f * diag_, c.z_far = 100.0f * diag_;
    return c;
  }

  Query random_query() {
    Query q;
    const std::uint32_t kind = std::uniform_int_distribution<std::uint32_t>(0, 3)(rng_);
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    if (kind == 0) {
      q.criterion = Criterion::object_error(diag_ * 0.05f * u(rng_) * u(rng_));
    } else {
      const Camera cam = random_camera();
      std::vector<Criterion> parts = {Criterion::outside_frustum(cam.frustum()), Criterion::screen_error(cam, 600.0f, 0.5f + 8.0f * u(rng_))};
      if (kind >= 2) parts.push_back(Criterion::back_facing(cam.eye));
      q.criterion = Criterion::any_of(std::move(parts));
    }
    if (std::bernoulli_distribution(0.3)(rng_))
      q.triangle_budget = std::uniform_int_distribution<std::size_t>(h_.base_faces().size() + 1, h_.num_faces() + 10)(rng_);
    return q;
  }

  std::string query_phase(std::size_t phase) {
    const int frames = std::uniform_int_distribution<int>(1, 8)(rng_);
    const bool baseline = sr_.scheme() != RefinementScheme::kKimLee;
    for (int frame = 0; frame < frames; ++frame) {
      const Query q = random_query();
      const bool use_update = std::bernoulli_distribution(0.6)(rng_);
      const QueryStats st = use_update ? update(sr_, q) : extract(sr_, q);
      ++totals_.queries;
      const std::string where = "query phase " + std::to_string(phase) + " frame " + std::to_string(frame) + (use_update ? " (update" : " (extract") +
                                (q.triangle_budget ? ", budget " + std::to_string(q.triangle_budget) + ")" : ")") + ": ";
      std::string p = validate();
      if (p.empty()) p = testing::compare_with_oracle(sr_);
      if (!p.empty()) return where + p;
      if (q.triangle_budget) {
        if (sr_.num_faces() > q.triangle_budget && sr_.num_faces() > h_.base_faces().size())
          return where + std::to_string(sr_.num_faces()) + " faces over the budget";
        continue;
      }
      if (st.time_reached) continue;
      if (!is_fixpoint(sr_, q)) return where + "not a fixpoint of the query";
      if (baseline && use_update) {
        // Under Hoppe-97 and Xia-Varshney update() reaches extract()'s answer (sr_mesh.hpp, query API note).
        SrMesh fresh(h_, sr_.scheme());
        extract(fresh, q);
        for (Index v = static_cast<Index>(h_.num_leaves()); v < h_.num_nodes(); ++v)
          if (fresh.is_refined(v) != sr_.is_refined(v)) return where + "update() differs from extract() at node " + std::to_string(v);
      }
    }
    return "";
  }

  std::string full_round_trip(const std::string& when) {
    sr_.refine_all();
    std::string p = validate();
    if (p.empty() && !testing::same_as_original(sr_)) p = "refine_all is not the original mesh";
    if (p.empty()) p = testing::differs_from_input(sr_, input_);
    if (p.empty()) {
      sr_.coarsen_all();
      p = validate();
    }
    if (p.empty() && !testing::at_base(sr_)) p = "coarsen_all stopped at " + std::to_string(sr_.num_active_vertices()) + " vertices";
    if (p.empty()) p = testing::compare_with_oracle(sr_);
    return p.empty() ? "" : when + ": " + p;
  }

  std::string validate() const {
    try {
      sr_.validate();
    } catch (const std::exception& e) {
      return std::string("validate: ") + e.what();
    }
    return "";
  }

  const VertexHierarchy& h_;
  const TriMesh& input_;
  SrMesh sr_;
  std::mt19937 rng_;
  testing::Subtrees t_;
  std::size_t full_every_;
  glm::vec3 center_{0.0f};
  float diag_ = 1.0f;
  Totals totals_;
};

// encode(h) -> decode -> encode gives the same bytes, and the decoded hierarchy validates.
std::string round_trip(const VertexHierarchy& h, VertexHierarchy& decoded) {
  const std::vector<std::uint8_t> bytes = encode_vertex_hierarchy(h);
  decoded = decode_vertex_hierarchy(bytes, "soak");
  decoded.validate();
  if (encode_vertex_hierarchy(decoded) != bytes) return "encode(decode(bytes)) differs from bytes";
  return "";
}

int main_impl(int argc, char** argv) {
  double seconds = 600, case_seconds = 20;
  std::uint32_t seed = 1;
  std::size_t full_every = 5;
  bool with_fixtures = false;
  std::string only_option, only_scheme;
  std::vector<std::string> files;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto next = [&]() -> std::string {
      if (i + 1 >= argc) throw InvalidInput(a + " needs a value");
      return argv[++i];
    };
    if (a == "--seconds") seconds = std::stod(next());
    else if (a == "--case-seconds") case_seconds = std::stod(next());
    else if (a == "--seed") seed = static_cast<std::uint32_t>(std::stoul(next()));
    else if (a == "--full-every") full_every = std::stoul(next());
    else if (a == "--fixtures") with_fixtures = true;
    else if (a == "--only-option") only_option = next();
    else if (a == "--only-scheme") only_scheme = next();
    else files.push_back(a);
  }
  const Clock::time_point start = Clock::now(), end = start + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(seconds));
  std::vector<NamedMesh> meshes;
  if (with_fixtures) meshes = fixtures();
  for (const std::string& f : files) meshes.push_back({std::filesystem::path(f).filename().string(), read_mesh(f)});
  int failures = 0;
  std::size_t cases = 0;
  Totals all;
  std::size_t per_scheme[3] = {0, 0, 0};
  for (const NamedMesh& nm : meshes) {
    for (const NamedOptions& no : option_sets(nm.mesh)) {
      if (!only_option.empty() && no.name != only_option) continue;
      if (Clock::now() >= end) break;
      const Clock::time_point t0 = Clock::now();
      VertexHierarchy h, decoded;
      std::string p;
      try {
        h = build_vertex_hierarchy(nm.mesh, no.options);
        h.validate();
        p = round_trip(h, decoded);
      } catch (const std::exception& e) {
        p = std::string("build/validate/round trip threw: ") + e.what();
      }
      std::printf("%s %s: %zu leaves, %zu nodes, %zu faces, base %zu faces, built in %.1f s%s%s\n", nm.name.c_str(), no.name.c_str(),
                  h.num_leaves(), h.num_nodes(), h.num_faces(), h.base_faces().size(), seconds_since(t0), p.empty() ? "" : ": FAIL ",
                  p.c_str());
      std::fflush(stdout);
      if (!p.empty()) {
        ++failures;
        continue;
      }
      for (int si = 0; si < 3; ++si) {
        const auto s = static_cast<RefinementScheme>(si);
        if (!only_scheme.empty() && only_scheme != scheme_name(s)) continue;
        if (Clock::now() >= end) break;
        const std::uint32_t case_seed = seed * 7919u + static_cast<std::uint32_t>(cases++) * 104729u;
        // Alternate between the built hierarchy and its decoded copy (the same bytes) so that the walks also
        // run on what decode derives.
        const VertexHierarchy& use = (case_seed + static_cast<std::uint32_t>(si)) % 2 ? decoded : h;
        const Clock::time_point c0 = Clock::now();
        const Clock::time_point deadline = std::min(end, c0 + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(case_seconds)));
        Totals t;
        try {
          Soak soak(use, s, nm.mesh, case_seed, full_every);
          p = soak.run(deadline);
          t = soak.totals();
        } catch (const std::exception& e) {
          p = std::string("threw: ") + e.what();
        }
        std::printf("  %-16s %-14s %-12s seed %10u: %8zu requests, %8zu ops, %5zu queries, %6zu full checks, %5zu oracle checks, "
                    "%5zu presplits, %5zu postponed, %.1f s%s%s\n",
                    nm.name.c_str(), no.name.c_str(), scheme_name(s), case_seed, t.requests, t.ops, t.queries, t.full_checks,
                    t.oracle_checks, t.presplits, t.postponed, seconds_since(c0), p.empty() ? " ok" : "\n  FAIL: ", p.c_str());
        std::fflush(stdout);
        per_scheme[si] += t.requests;
        all.requests += t.requests, all.ops += t.ops, all.queries += t.queries;
        if (!p.empty()) ++failures;
      }
    }
  }
  std::printf("TOTAL seed %u: %zu cases, %zu requests (kim-lee %zu, hoppe97 %zu, xia-varshney %zu), %zu ops, %zu queries, %d failed, %.1f s\n",
              seed, cases, all.requests, per_scheme[0], per_scheme[1], per_scheme[2], all.ops, all.queries, failures, seconds_since(start));
  return std::min(failures, 255);
}

}  // namespace
}  // namespace varmesh

int main(int argc, char** argv) {
  try {
    return varmesh::main_impl(argc, argv);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "pm_soak: %s\n", e.what());
    return 255;
  }
}
