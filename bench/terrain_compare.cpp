// Terrain benchmark for BENCHMARKS.md: build time and memory of the 4-8 hierarchy, extraction rate at
// thresholds giving about 10k, 100k and 1M triangles, measured error of every extracted mesh, and a
// 60-frame flyover (incremental update() against extraction from scratch). It also writes each terrain
// as a (2^k+1)^2 float32 file plus a manifest so that bench/martini_compare.mjs runs mapbox/martini on the
// same heights and thresholds. Times are medians of back-to-back runs on this machine. "extract ms" is
// Grid48Front::extract_mesh (one fused descent); extract_fast + to_mesh, the two-call path, is shown too.
//
// usage: varmesh_terrain_bench OUT_DIR [SHARED_DATA_DIR]
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <optional>
#include <string>
#include <vector>

#include "fourk/grid48.hpp"
#include "multitri/heightfield.hpp"
#include "multitri/query.hpp"
#include "multitri/terrain_gen.hpp"

using namespace varmesh;
using Clock = std::chrono::steady_clock;

namespace {

double ms_since(Clock::time_point t) { return std::chrono::duration<double, std::milli>(Clock::now() - t).count(); }

// Median of back-to-back runs of timed() (each after an untimed setup()): at least 9 runs, and for short
// ones more, until about 200 ms have been timed (at most 401 runs). martini_compare.mjs times martini's
// construction, error map and getMesh by the same rule, so both sides are measured as repeated calls on
// warm data.
template <class Setup, class Timed>
double median_block_ms(Setup&& setup, Timed&& timed) {
  std::vector<double> t;
  double total = 0.0;
  while (t.size() < 9 || (total < 200.0 && t.size() < 401)) {
    setup();
    const auto s = Clock::now();
    timed();
    t.push_back(ms_since(s));
    total += t.back();
  }
  std::sort(t.begin(), t.end());
  return t[t.size() / 2];
}

struct Case {
  std::string name;
  HeightField field;
};

// The threshold whose uniform extraction gives about `target` triangles (bisection on a log scale).
float threshold_for(const Grid48& g, std::size_t target) {
  float lo = 1e-4f, hi = 1e4f;
  Grid48Front f(g);
  for (int it = 0; it < 40; ++it) {
    const float mid = std::sqrt(lo * hi);
    Query q;
    q.criterion = Criterion::object_error(mid);
    f.extract_fast(q);
    if (f.num_faces() > target) lo = mid; else hi = mid;
  }
  return hi;
}

// Writes the field padded to (2^k+1)^2 by repeating the last row/column (what martini users must do).
std::size_t write_martini_input(const HeightField& f, const std::string& path) {
  std::size_t n = 2;
  while (n + 1 < std::max(f.width, f.height)) n *= 2;
  const std::size_t s = n + 1;
  std::vector<float> z(s * s);
  for (std::size_t y = 0; y < s; ++y)
    for (std::size_t x = 0; x < s; ++x) z[y * s + x] = f.at(std::min(x, f.width - 1), std::min(y, f.height - 1));
  std::ofstream(path, std::ios::binary).write(reinterpret_cast<const char*>(z.data()), std::streamsize(z.size() * 4));
  return s;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: %s OUT_DIR [SHARED_DATA_DIR]\n", argv[0]);
    return 2;
  }
  const std::string out = argv[1];
  const std::string data = argc > 2 ? argv[2] : "../shared/data";
  std::filesystem::create_directories(out);
  std::vector<Case> cases;
  cases.push_back({"fractal1025", make_fractal_terrain(1025, 1025, 7, 300.0f)});
  try {
    HeightFieldReadOptions o;
    o.raw_width = o.raw_height = 512;
    cases.push_back({"fuji512", read_heightfield(data + "/terrain/fuji_elevation_512_f32le.raw", o)});
    cases.push_back({"jacksboro403x344", read_heightfield(data + "/terrain/jacksboro_fault_dem_403x344.pgm")});
  } catch (const std::exception& e) {
    std::fprintf(stderr, "shared terrains skipped: %s\n", e.what());
  }
  std::ofstream manifest(out + "/manifest.json");
  manifest << "[\n";
  std::printf("%-18s %-6s %10s %8s | %9s %10s %10s %10s %9s\n", "terrain", "errors", "build ms", "B/sample", "threshold",
              "triangles", "extract ms", "Mtri/s", "max err");
  bool first_case = true;
  for (auto& c : cases) {
    const std::size_t samples = c.field.width * c.field.height;
    std::vector<float> thresholds;
    for (bool exact : {true, false}) {
      Grid48Options go;
      go.exact_errors = exact;
      const double build = median_block_ms([] {}, [&] { Grid48 g(c.field, go); });
      const Grid48 g(c.field, go);
      const double bps = double(g.memory_bytes()) / double(samples);
      const std::size_t targets[] = {10000, 100000, 1000000};
      for (std::size_t ti = 0; ti < 3; ++ti) {
        if (targets[ti] > 2 * samples) continue;
        // Thresholds are chosen on the default (exact) hierarchy and reused for the fast bound.
        const float thr = exact ? threshold_for(g, targets[ti]) : thresholds[ti];
        if (exact) thresholds.push_back(thr);
        Grid48Front f(g);
        Query q;
        q.criterion = Criterion::object_error(thr);
        TriMesh mesh, mesh2;
        // The two ways to get the mesh, each timed in its own block of back-to-back runs on one front, and
        // on fresh fronts (one extraction per front, as `varmesh terrain` does; construction not timed).
        const double ext = median_block_ms([] {}, [&] { mesh = f.extract_mesh(q); });
        const double two = median_block_ms([] {}, [&] {
          f.extract_fast(q);
          mesh2 = f.to_mesh();
        });
        std::optional<Grid48Front> fresh;
        const double fused_fresh = median_block_ms([&] { fresh.emplace(g); }, [&] { (void)fresh->extract_mesh(q); });
        const double two_fresh = median_block_ms([&] { fresh.emplace(g); }, [&] {
          fresh->extract_fast(q);
          (void)fresh->to_mesh();
        });
        const double err = std::max(g.max_vertical_error(mesh), g.max_vertical_error(mesh2));
        std::printf("%-18s %-6s %10.1f %8.1f | %9.4g %10zu %10.2f %10.1f %9.4g%s | extract_fast + to_mesh %.2f ms%s"
                    " | fresh front: extract_mesh %.2f, two calls %.2f ms\n",
                    c.name.c_str(), exact ? "exact" : "bound", build, bps, double(thr), mesh.num_faces(), ext,
                    double(mesh.num_faces()) / ext / 1000.0, err, err > double(thr) ? "  VIOLATION" : "", two,
                    mesh2.num_faces() == mesh.num_faces() ? "" : "  MISMATCH", fused_fresh, two_fresh);
      }
    }
    // Flyover: 60 frames, camera gliding across the terrain at a fixed height, 1 px on 1080 lines.
    // Incremental: Grid48Front::update_view (frame coherence) and the generic update(); from scratch:
    // extract_fast. Each method flies the whole path on its own (frame i starts from frame i - 1's state),
    // so that it keeps its data in cache as an application would; three rounds, median over all frames.
    // All three must give the same mesh every frame.
    {
      const Grid48 g(c.field);
      Grid48Front coherent(g), generic(g), fresh(g);
      const float w = float(c.field.width - 1), h = float(c.field.height - 1);
      const auto [zmin, zmax] = std::minmax_element(c.field.z.begin(), c.field.z.end());
      constexpr int kFrames = 60, kRounds = 3;
      std::vector<ViewQuery> views;
      std::vector<Query> queries;
      for (int i = 0; i <= kFrames; ++i) {
        ViewQuery v;
        const float s = float(i) / float(kFrames);
        v.camera.eye = {0.1f * w + 0.3f * w * s, 0.1f * h + 0.2f * h * s, *zmax + 0.1f * (*zmax - *zmin)};
        v.camera.target = v.camera.eye + glm::vec3(0.5f * w, 0.5f * h, -0.6f * (*zmax - *zmin));
        v.camera.fov_y_deg = 50.0f;
        v.camera.aspect = 16.0f / 9.0f;
        v.camera.z_near = 0.5f;
        v.camera.z_far = 10.0f * std::max(w, h);
        views.push_back(v);
        queries.push_back(v.to_query());
      }
      std::vector<double> t_view, t_gen, t_fresh;
      std::vector<std::size_t> f_view(kFrames + 1), f_gen(kFrames + 1), f_fresh(kFrames + 1);
      std::size_t faces = 0, mismatches = 0;
      for (int round = 0; round < kRounds; ++round) {
        coherent.update_view(views[0]);
        for (int i = 1; i <= kFrames; ++i) {
          const auto t0 = Clock::now();
          coherent.update_view(views[static_cast<std::size_t>(i)]);
          t_view.push_back(ms_since(t0));
          f_view[static_cast<std::size_t>(i)] = coherent.num_faces();
        }
        update(generic, queries[0]);
        for (int i = 1; i <= kFrames; ++i) {
          const auto t0 = Clock::now();
          update(generic, queries[static_cast<std::size_t>(i)]);
          t_gen.push_back(ms_since(t0));
          f_gen[static_cast<std::size_t>(i)] = generic.num_faces();
        }
        for (int i = 1; i <= kFrames; ++i) {
          const auto t0 = Clock::now();
          fresh.extract_fast(queries[static_cast<std::size_t>(i)]);
          t_fresh.push_back(ms_since(t0));
          f_fresh[static_cast<std::size_t>(i)] = fresh.num_faces();
        }
        for (int i = 1; i <= kFrames; ++i) {
          const std::size_t k = static_cast<std::size_t>(i);
          if (round == 0) faces += f_fresh[k];
          if (f_view[k] != f_fresh[k] || f_gen[k] != f_fresh[k]) ++mismatches;
        }
      }
      if (mismatches > 0) std::printf("  MISMATCH in %zu frames\n", mismatches);
      std::sort(t_view.begin(), t_view.end());
      std::sort(t_gen.begin(), t_gen.end());
      std::sort(t_fresh.begin(), t_fresh.end());
      const std::size_t mid = t_view.size() / 2;
      std::printf("%-18s flyover, %d frames x %d rounds, ~%zu triangles, median ms/frame: update_view %.2f, update "
                  "%.2f, extract_fast %.2f; from scratch / update_view = %.1fx\n",
                  c.name.c_str(), kFrames, kRounds, faces / kFrames, t_view[mid], t_gen[mid], t_fresh[mid],
                  t_fresh[mid] / t_view[mid]);
    }
    const std::string raw = std::filesystem::absolute(out + "/" + c.name + ".f32").string();
    const std::size_t s = write_martini_input(c.field, raw);
    manifest << (first_case ? "" : ",\n") << "  {\"name\": \"" << c.name << "\", \"file\": \"" << raw << "\", \"size\": " << s
             << ", \"width\": " << c.field.width << ", \"height\": " << c.field.height << ", \"thresholds\": [";
    for (std::size_t i = 0; i < thresholds.size(); ++i) manifest << (i ? ", " : "") << thresholds[i];
    manifest << "]}";
    first_case = false;
  }
  manifest << "\n]\n";
  return 0;
}
