// Terrain benchmark for BENCHMARKS.md: build time and memory of the 4-8 hierarchy, extraction rate at
// thresholds giving about 10k, 100k and 1M triangles, measured error of every extracted mesh, and a
// 60-frame flyover (incremental update() against extraction from scratch). It also writes each terrain
// as a (2^k+1)^2 float32 file plus a manifest so that bench/martini_compare.mjs runs mapbox/martini on the
// same heights and thresholds. Times are medians of repeated runs on this machine.
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
    for (bool exact : {false, true}) {
      Grid48Options go;
      go.exact_errors = exact;
      const double build = median_ms(exact ? 3 : 5, [&] { Grid48 g(c.field, go); });
      const Grid48 g(c.field, go);
      const double bps = double(g.memory_bytes()) / double(samples);
      std::size_t targets[] = {10000, 100000, 1000000};
      for (std::size_t target : targets) {
        if (target > 2 * samples) continue;
        const float thr = exact ? thresholds[&target - targets] : threshold_for(g, target);
        if (!exact) thresholds.push_back(thr);
        Grid48Front f(g);
        Query q;
        q.criterion = Criterion::object_error(thr);
        TriMesh mesh;
        const double ext = median_ms(7, [&] {
          f.extract_fast(q);
          mesh = f.to_mesh();
        });
        const double err = g.max_vertical_error(mesh);
        std::printf("%-18s %-6s %10.1f %8.1f | %9.4g %10zu %10.2f %10.1f %9.4g%s\n", c.name.c_str(), exact ? "exact" : "bound",
                    build, bps, double(thr), mesh.num_faces(), ext, double(mesh.num_faces()) / ext / 1000.0, err,
                    err > double(thr) ? "  VIOLATION" : "");
      }
    }
    // Flyover: 60 frames, camera gliding across the terrain at a fixed height, 1 px on 1080 lines.
    {
      const Grid48 g(c.field);
      Grid48Front inc(g), fresh(g);
      const float w = float(c.field.width - 1), h = float(c.field.height - 1);
      const auto [zmin, zmax] = std::minmax_element(c.field.z.begin(), c.field.z.end());
      std::vector<double> t_inc, t_fresh;
      std::size_t faces = 0;
      for (int i = 0; i < 61; ++i) {
        Camera cam;
        const float s = float(i) / 60.0f;
        cam.eye = {0.1f * w + 0.3f * w * s, 0.1f * h + 0.2f * h * s, *zmax + 0.1f * (*zmax - *zmin)};
        cam.target = cam.eye + glm::vec3(0.5f * w, 0.5f * h, -0.6f * (*zmax - *zmin));
        cam.fov_y_deg = 50.0f;
        cam.aspect = 16.0f / 9.0f;
        cam.z_near = 0.5f;
        cam.z_far = 10.0f * std::max(w, h);
        Query q;
        q.criterion = Criterion::any_of({Criterion::outside_frustum(cam.frustum()), Criterion::screen_error(cam, 1080.0f, 1.0f)});
        auto t0 = Clock::now();
        update(inc, q);
        const double ti = ms_since(t0);
        t0 = Clock::now();
        fresh.extract_fast(q);
        const double tf = ms_since(t0);
        if (i > 0) {
          t_inc.push_back(ti);
          t_fresh.push_back(tf);
        }
        faces += inc.num_faces();
        if (inc.num_faces() != fresh.num_faces()) std::printf("  MISMATCH frame %d\n", i);
      }
      std::sort(t_inc.begin(), t_inc.end());
      std::sort(t_fresh.begin(), t_fresh.end());
      std::printf("%-18s flyover 60 frames, ~%zu triangles: update %.2f ms/frame, extract %.2f ms/frame (median), ratio %.2f\n",
                  c.name.c_str(), faces / 61, t_inc[30], t_fresh[30], t_fresh[30] / t_inc[30]);
    }
    const std::string raw = out + "/" + c.name + ".f32";
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
