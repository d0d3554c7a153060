// A program outside the varmesh tree, built against the installed package: a 4-8 terrain hierarchy
// extracted within an error bound, and a progressive-mesh hierarchy refined selectively, by hand and by a
// view query. Exits non-zero if anything is off, so CI notices a broken install. The pm part is the example
// README's "Progressive meshes" section shows.
#include <cstdio>

#include <fourk/grid48.hpp>
#include <multitri/camera.hpp>
#include <multitri/query.hpp>
#include <multitri/shapes.hpp>
#include <multitri/terrain_gen.hpp>
#include <pm/qem_analysis.hpp>
#include <pm/sr_mesh.hpp>

namespace {

bool terrain() {
  const varmesh::HeightField field = varmesh::make_fractal_terrain(65, 65, 1, 20.0f);
  const varmesh::Grid48 hierarchy(field);
  varmesh::Grid48Front front(hierarchy);
  varmesh::Query q;
  q.criterion = varmesh::Criterion::object_error(0.5f);
  varmesh::extract(front, q);
  const varmesh::TriMesh mesh = front.to_mesh();
  const double error = hierarchy.max_vertical_error(mesh);
  std::printf("consumer: terrain %zu triangles, max vertical error %.3f (asked 0.5)\n", mesh.num_faces(), error);
  return mesh.num_faces() > 2 && error <= 0.5;
}

bool progressive_mesh() {
  const varmesh::TriMesh mesh = varmesh::make_torus(48, 24, 1.0f, 0.35f, 0.1f);  // or varmesh::read_mesh(path)
  const varmesh::VertexHierarchy h = varmesh::build_vertex_hierarchy(mesh);     // down to the smallest base mesh
  varmesh::SrMesh sr(h);  // RefinementScheme::kKimLee; kHoppe97 and kXiaVarshney give the baselines

  // By hand: split any active vertex that has children, then collapse it again (section 4 of the paper).
  varmesh::Index vs = varmesh::kInvalid;
  for (const varmesh::Index v : sr.active_vertices())
    if (!h.is_leaf(v)) vs = v;
  const std::size_t before = sr.num_active_vertices();
  const bool split = vs != varmesh::kInvalid && sr.vsplit(vs);
  const bool one_more = sr.num_active_vertices() == before + 1;
  const bool collapsed = split && sr.ecol(vs);  // false only when postponed (degenerate case, section 4.4)

  // By query: fine where the camera looks, coarse elsewhere; update() moves the same front for a new view.
  varmesh::Camera cam;
  cam.eye = {3.0f, 0.0f, 1.0f};
  cam.target = {0.0f, 0.0f, 0.0f};
  varmesh::Query q;
  q.criterion = varmesh::Criterion::screen_error(cam, 1080.0f, 1.0f);
  q.focus.frusta = {cam.frustum()};
  varmesh::extract(sr, q);
  const std::size_t near_faces = sr.num_faces();
  cam.eye = {6.0f, 0.0f, 2.0f};  // twice as far: fewer faces
  q.criterion = varmesh::Criterion::screen_error(cam, 1080.0f, 1.0f);
  q.focus.frusta = {cam.frustum()};
  varmesh::update(sr, q);
  const varmesh::TriMesh out = sr.to_mesh();
  std::printf("consumer: pm %zu -> %zu nodes; vsplit %d ecol %d; %zu faces near, %zu far\n", mesh.num_vertices(),
              h.num_nodes(), split, collapsed, near_faces, out.num_faces());
  return split && one_more && near_faces > out.num_faces() && out.num_faces() > 0;
}

}  // namespace

int main() {
  const bool ok_terrain = terrain();
  const bool ok_pm = progressive_mesh();
  return ok_terrain && ok_pm ? 0 : 1;
}
