// Terrain benchmark for BENCHMARKS.md: build time and memory of the 4-8 hierarchy, extraction rate at
// thresholds giving about 10k, 100k and 1M triangles, measured error of every extracted mesh, and a
// 60-frame flyover (incremental update() against extraction from scratch). It also writes each terrain
// as a (2^k+1)^2 float32 file plus a manifest so that bench/martini_compare.mjs runs mapbox/martini on the
// same heights and thresholds. Times are medians of repeated runs on this machine. "extract ms" is
// Grid48Front::extract_mesh (one fused descent); extract_fast + to_mesh, the two-call path, is shown too.
//
// usage: varmesh_terrain_bench OUT_DIR [SHARED_DATA_DIR]
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
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

template <class F>
double median_ms(int runs, F&& f) {
  std::vector<double> t;
  for (int i = 0; i < runs; ++i) {
    const auto s = Clock::now();
    f();
    t.push_back(ms_since(s));
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
      const double build = median_ms(exact ? 3 : 5, [&] { Grid48 g(c.field, go); });
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
        // The two ways to get the mesh, interleaved so that both see the same machine load.
        // Also on fresh fronts (one extraction per front, as `varmesh terrain` does; construction not timed).
        std::vector<double> t_fused, t_two, t_fused_fresh, t_two_fresh;
        for (int r = 0; r < 9; ++r) {
          auto t0 = Clock::now();
          mesh = f.extract_mesh(q);
          t_fused.push_back(ms_since(t0));
          t0 = Clock::now();
          f.extract_fast(q);
          mesh2 = f.to_mesh();
          t_two.push_back(ms_since(t0));
          {
            Grid48Front fresh(g);
            t0 = Clock::now();
            const TriMesh m = fresh.extract_mesh(q);
            t_fused_fresh.push_back(ms_since(t0));
          }
          {
            Grid48Front fresh(g);
            t0 = Clock::now();
            fresh.extract_fast(q);
            const TriMesh m = fresh.to_mesh();
            t_two_fresh.push_back(ms_since(t0));
          }
        }
        for (auto* t : {&t_fused, &t_two, &t_fused_fresh, &t_two_fresh}) std::sort(t->begin(), t->end());
        const double ext = t_fused[4], two = t_two[4];
        const double err = std::max(g.max_vertical_error(mesh), g.max_vertical_error(mesh2));
        std::printf("%-18s %-6s %10.1f %8.1f | %9.4g %10zu %10.2f %10.1f %9.4g%s | extract_fast + to_mesh %.2f ms%s"
                    " | fresh front: extract_mesh %.2f, two calls %.2f ms\n",
                    c.name.c_str(), exact ? "exact" : "bound", build, bps, double(thr), mesh.num_faces(), ext,
                    double(mesh.num_faces()) / ext / 1000.0, err, err > double(thr) ? "  VIOLATION" : "", two,
                    mesh2.num_faces() == mesh.num_faces() ? "" : "  MISMATCH", t_fused_fresh[4], t_two_fresh[4]);
      }
    }
    // Flyover: 60 frames, camera gliding across the terrain at a fixed height, 1 px on 1080 lines.
    // Incremental: Grid48Front::update_view (frame coherence) and the generic update(); from scratch:
    // extract_fast. All three must give the same mesh every frame.
    {
      const Grid48 g(c.field);
      Grid48Front coherent(g), generic(g), fresh(g);
      const float w = float(c.field.width - 1), h = float(c.field.height - 1);
      const auto [zmin, zmax] = std::minmax_element(c.field.z.begin(), c.field.z.end());
      std::vector<double> t_view, t_gen, t_fresh;
      std::size_t faces = 0;
      for (int i = 0; i < 61; ++i) {
        ViewQuery v;
        const float s = float(i) / 60.0f;
        v.camera.eye = {0.1f * w + 0.3f * w * s, 0.1f * h + 0.2f * h * s, *zmax + 0.1f * (*zmax - *zmin)};
        v.camera.target = v.camera.eye + glm::vec3(0.5f * w, 0.5f * h, -0.6f * (*zmax - *zmin));
        v.camera.fov_y_deg = 50.0f;
        v.camera.aspect = 16.0f / 9.0f;
        v.camera.z_near = 0.5f;
        v.camera.z_far = 10.0f * std::max(w, h);
        const Query q = v.to_query();
        auto t0 = Clock::now();
        coherent.update_view(v);
        const double tv = ms_since(t0);
        t0 = Clock::now();
        update(generic, q);
        const double tg = ms_since(t0);
        t0 = Clock::now();
        fresh.extract_fast(q);
        const double tf = ms_since(t0);
        if (i > 0) {
          t_view.push_back(tv);
          t_gen.push_back(tg);
          t_fresh.push_back(tf);
        }
        faces += fresh.num_faces();
        if (coherent.num_faces() != fresh.num_faces() || generic.num_faces() != fresh.num_faces())
          std::printf("  MISMATCH frame %d\n", i);
      }
      std::sort(t_view.begin(), t_view.end());
      std::sort(t_gen.begin(), t_gen.end());
      std::sort(t_fresh.begin(), t_fresh.end());
      std::printf("%-18s flyover, 60 frames, ~%zu triangles, median ms/frame: update_view %.2f, update %.2f, "
                  "extract_fast %.2f; from scratch / update_view = %.1fx\n",
                  c.name.c_str(), faces / 61, t_view[30], t_gen[30], t_fresh[30], t_fresh[30] / t_view[30]);
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
