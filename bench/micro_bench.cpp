// Google Benchmark micro-benchmarks of the 4-8 terrain hierarchy: build, extraction at three thresholds,
// and one incremental update after a small camera move.
#include <benchmark/benchmark.h>

#include "fourk/grid48.hpp"
#include "multitri/query.hpp"
#include "multitri/terrain_gen.hpp"

using namespace varmesh;

namespace {

const HeightField& terrain() {
  static const HeightField f = make_fractal_terrain(1025, 1025, 7, 300.0f);
  return f;
}

void BM_Grid48Build(benchmark::State& state) {
  Grid48Options o;
  o.exact_errors = state.range(0) != 0;
  for (auto _ : state) {
    Grid48 g(terrain(), o);
    benchmark::DoNotOptimize(g.error(1));
  }
  state.SetItemsProcessed(state.iterations() * static_cast<std::int64_t>(terrain().z.size()));
}
BENCHMARK(BM_Grid48Build)->Arg(0)->Arg(1)->Unit(benchmark::kMillisecond);

void BM_Grid48Extract(benchmark::State& state) {
  static const Grid48 g(terrain());
  Grid48Front f(g);
  Query q;
  q.criterion = Criterion::object_error(static_cast<float>(state.range(0)) / 100.0f);
  std::size_t faces = 0;
  for (auto _ : state) {
    f.extract_fast(q);
    TriMesh m = f.to_mesh();
    faces = m.num_faces();
    benchmark::DoNotOptimize(m.indices.data());
  }
  state.counters["triangles"] = static_cast<double>(faces);
  state.SetItemsProcessed(state.iterations() * static_cast<std::int64_t>(faces));
}
BENCHMARK(BM_Grid48Extract)->Arg(1000)->Arg(200)->Arg(20)->Unit(benchmark::kMillisecond);

void BM_Grid48UpdateSmallMove(benchmark::State& state) {
  static const Grid48 g(terrain());
  Grid48Front f(g);
  auto query = [](float dx) {
    Camera cam;
    cam.eye = {100.0f + dx, 100.0f, 450.0f};
    cam.target = {600.0f + dx, 600.0f, 50.0f};
    cam.z_near = 0.5f;
    cam.z_far = 10000.0f;
    Query q;
    q.criterion = Criterion::any_of({Criterion::outside_frustum(cam.frustum()), Criterion::screen_error(cam, 1080.0f, 1.0f)});
    return q;
  };
  const Query a = query(0.0f), b = query(1.0f);
  extract(f, a);
  bool flip = false;
  for (auto _ : state) {
    update(f, flip ? a : b);
    flip = !flip;
  }
  state.counters["triangles"] = static_cast<double>(f.num_faces());
}
BENCHMARK(BM_Grid48UpdateSmallMove)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
