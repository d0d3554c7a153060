// Selective refinement to a predicate and the inputs of Kim-Lee 2001 section 5 (Table 2, Figures 8-9).
// Papers: J. Kim, S. Lee, "Truly selective refinement of progressive meshes", GI 2001; I. Sobel, G. Feldman,
// "A 3x3 isotropic gradient operator for image processing" (1968), the feature mask of the image experiment.
#include "pm/selective_refine.hpp"

#include <algorithm>
#include <cmath>
#include <functional>
#include <queue>
#include <string>

#include "multitri/errors.hpp"

namespace varmesh {

SelectiveRefineResult refine_to_predicate(SrMesh& mesh, const std::function<bool(Index)>& needs_refinement,
                                          std::size_t max_rounds) {
  if (max_rounds == 0) throw InvalidInput("refine_to_predicate: max_rounds must be >= 1");
  if (!needs_refinement) throw InvalidInput("refine_to_predicate: needs_refinement is an empty std::function");
  const VertexHierarchy& h = mesh.hierarchy();
  const Index first_inner = static_cast<Index>(h.num_leaves());
  const Index num_nodes = static_cast<Index>(h.num_nodes());
  const SrStats before = mesh.stats();
  SelectiveRefineResult out;
  auto needy = [&](Index v) { return v >= first_inner && mesh.is_active(v) && needs_refinement(v); };
  // Coarsest first: larger ids were collapsed later, so splitting in decreasing id order replays the
  // progressive mesh where it is needed, which is the order the Hoppe and Xia-Varshney rules expect.
  std::priority_queue<Index> heap;
  for (;;) {
    for (Index v = first_inner; v < num_nodes; ++v)
      if (needy(v)) heap.push(v);
    if (heap.empty() || out.rounds == max_rounds) break;
    ++out.rounds;
    while (!heap.empty()) {
      const Index v = heap.top();
      heap.pop();
      if (!needy(v)) continue;
      if (!mesh.vsplit(v)) {
        ++out.refused_vsplits;
        continue;
      }
      ++out.requested_vsplits;
      for (Index c : {h.vt(v), h.vu(v)})
        if (needy(c)) heap.push(c);
    }
  }
  while (!heap.empty()) heap.pop();
  for (Index v = first_inner; v < num_nodes; ++v)
    if (needy(v)) ++out.unsatisfied;
  const SrStats& after = mesh.stats();
  out.stats.vsplits = after.vsplits - before.vsplits;
  out.stats.ecols = after.ecols - before.ecols;
  out.stats.forced_vsplits = after.forced_vsplits - before.forced_vsplits;
  out.stats.forced_ecols = after.forced_ecols - before.forced_ecols;
  out.stats.degenerate_cases = after.degenerate_cases - before.degenerate_cases;
  out.stats.presplits = after.presplits - before.presplits;
  out.stats.postponed_ecols = after.postponed_ecols - before.postponed_ecols;
  out.stats.refused_ecols = after.refused_ecols - before.refused_ecols;
  out.stats.failed_vsplits = after.failed_vsplits - before.failed_vsplits;
  return out;
}

std::vector<std::uint8_t> flag_ancestors(const VertexHierarchy& h, std::span<const std::uint8_t> leaf_flags) {
  if (leaf_flags.size() != h.num_leaves())
    throw InvalidInput("flag_ancestors: " + std::to_string(leaf_flags.size()) + " leaf flags for " +
                       std::to_string(h.num_leaves()) + " leaves");
  std::vector<std::uint8_t> flags(h.num_nodes(), 0);
  std::copy(leaf_flags.begin(), leaf_flags.end(), flags.begin());
  // Children are numbered before their parents, so one increasing pass carries every flag to the root.
  for (std::size_t v = 0; v < flags.size(); ++v) {
    const Index p = h.parent(static_cast<Index>(v));
    if (flags[v] && p != kInvalid) flags[p] = 1;
  }
  return flags;
}

std::vector<std::uint8_t> leaves_of_inputs(const VertexHierarchy& h, std::span<const Index> input_vertices) {
  // The asked vertices sorted, each with a found flag: memory in the size of the request, not of the
  // largest input id (a hierarchy file states its input's size).
  std::vector<Index> wanted(input_vertices.begin(), input_vertices.end());
  std::sort(wanted.begin(), wanted.end());
  wanted.erase(std::unique(wanted.begin(), wanted.end()), wanted.end());
  std::vector<std::uint8_t> found(wanted.size(), 0);
  const auto l2i = h.leaf_to_input();
  std::vector<std::uint8_t> leaves(h.num_leaves(), 0);
  for (std::size_t l = 0; l < l2i.size(); ++l) {
    const auto it = std::lower_bound(wanted.begin(), wanted.end(), l2i[l]);
    if (it == wanted.end() || *it != l2i[l]) continue;
    leaves[l] = 1;
    found[static_cast<std::size_t>(it - wanted.begin())] = 1;
  }
  for (std::size_t i = 0; i < wanted.size(); ++i)
    if (!found[i]) throw InvalidInput("leaves_of_inputs: input vertex " + std::to_string(wanted[i]) + " has no leaf", wanted[i]);
  return leaves;
}

namespace {

void check_image(const Image& image, const char* what) {
  const std::size_t n = image.width * image.height * static_cast<std::size_t>(std::max(image.channels, 0));
  const bool ok = image.width > 0 && image.height > 0 && image.channels >= 1 && image.channels <= 4 &&
                  ((image.bit_depth == 8 && image.pixels.size() == n) || (image.bit_depth == 16 && image.pixels16.size() == n));
  if (!ok) throw InvalidInput(std::string(what) + ": empty or inconsistent image");
}

glm::vec3 pixel_rgb(const Image& image, std::size_t x, std::size_t y) noexcept {
  if (image.channels >= 3) return {image.value(x, y, 0), image.value(x, y, 1), image.value(x, y, 2)};
  const float g = image.value(x, y, 0);
  return {g, g, g};
}

// Two counter-clockwise triangles per cell (seen from +z with +y up, i.e. with rows mapped to -y for images
// and +y for height fields: `flip_rows` tells which), diagonals alternating like a 4-8 mesh.
void grid_faces(std::size_t w, std::size_t h, bool flip_rows, std::vector<Index>& out) {
  out.reserve(6 * (w - 1) * (h - 1));
  auto id = [&](std::size_t x, std::size_t y) { return static_cast<Index>(y * w + x); };
  for (std::size_t y = 0; y + 1 < h; ++y)
    for (std::size_t x = 0; x + 1 < w; ++x) {
      // a, b, c, d counter-clockwise in the world's xy plane.
      Index a = id(x, y), b = id(x + 1, y), c = id(x + 1, y + 1), d = id(x, y + 1);
      if (flip_rows) {
        std::swap(a, d);
        std::swap(b, c);
      }
      if ((x + y) % 2 == 0) out.insert(out.end(), {a, b, c, a, c, d});
      else out.insert(out.end(), {a, b, d, b, c, d});
    }
}

// Blocks of `factor` covering n samples, the last one partial: n / factor rounded up, without the n + factor - 1
// that wraps round for a factor near SIZE_MAX.
std::size_t blocks(std::size_t n, std::size_t factor) noexcept { return n / factor + (n % factor != 0 ? 1 : 0); }

}  // namespace

Image downsample_image(const Image& image, std::size_t factor) {
  check_image(image, "downsample_image");
  if (factor < 1) throw InvalidInput("downsample_image: factor must be >= 1");
  Image out;
  out.width = blocks(image.width, factor);
  out.height = blocks(image.height, factor);
  out.channels = image.channels;
  out.bit_depth = 8;
  out.pixels.resize(out.width * out.height * static_cast<std::size_t>(out.channels));
  for (std::size_t oy = 0; oy < out.height; ++oy)
    for (std::size_t ox = 0; ox < out.width; ++ox)
      for (int c = 0; c < out.channels; ++c) {
        double sum = 0.0;
        std::size_t count = 0;
        for (std::size_t y = oy * factor; y < std::min(image.height, (oy + 1) * factor); ++y)
          for (std::size_t x = ox * factor; x < std::min(image.width, (ox + 1) * factor); ++x) {
            sum += image.value(x, y, c);
            ++count;
          }
        const double v = std::clamp(sum / static_cast<double>(count), 0.0, 1.0);
        out.pixels[(oy * out.width + ox) * static_cast<std::size_t>(out.channels) + static_cast<std::size_t>(c)] =
            static_cast<std::uint8_t>(std::lround(v * 255.0));
      }
  return out;
}

HeightField downsample_heightfield(const HeightField& field, std::size_t factor) {
  field.validate();
  if (factor < 1) throw InvalidInput("downsample_heightfield: factor must be >= 1");
  HeightField out;
  out.width = blocks(field.width, factor);
  out.height = blocks(field.height, factor);
  out.spacing_x = field.spacing_x * static_cast<float>(factor);
  out.spacing_y = field.spacing_y * static_cast<float>(factor);
  out.z.resize(out.width * out.height);
  for (std::size_t oy = 0; oy < out.height; ++oy)
    for (std::size_t ox = 0; ox < out.width; ++ox) {
      double sum = 0.0;
      std::size_t count = 0;
      for (std::size_t y = oy * factor; y < std::min(field.height, (oy + 1) * factor); ++y)
        for (std::size_t x = ox * factor; x < std::min(field.width, (ox + 1) * factor); ++x) {
          sum += field.at(x, y);
          ++count;
        }
      out.z[oy * out.width + ox] = static_cast<float>(sum / static_cast<double>(count));
    }
  return out;
}

float image_luma(const Image& image, std::size_t x, std::size_t y) noexcept {
  if (image.channels < 3) return image.value(x, y, 0);
  return 0.299f * image.value(x, y, 0) + 0.587f * image.value(x, y, 1) + 0.114f * image.value(x, y, 2);
}

std::vector<float> sobel_magnitude(const Image& image) {
  check_image(image, "sobel_magnitude");
  const std::size_t w = image.width, h = image.height;
  std::vector<float> luma(w * h);
  for (std::size_t y = 0; y < h; ++y)
    for (std::size_t x = 0; x < w; ++x) luma[y * w + x] = image_luma(image, x, y);
  auto at = [&](std::size_t x, std::ptrdiff_t dx, std::size_t y, std::ptrdiff_t dy) {
    const auto cx = static_cast<std::size_t>(std::clamp<std::ptrdiff_t>(static_cast<std::ptrdiff_t>(x) + dx, 0, static_cast<std::ptrdiff_t>(w) - 1));
    const auto cy = static_cast<std::size_t>(std::clamp<std::ptrdiff_t>(static_cast<std::ptrdiff_t>(y) + dy, 0, static_cast<std::ptrdiff_t>(h) - 1));
    return luma[cy * w + cx];
  };
  std::vector<float> mag(w * h);
  for (std::size_t y = 0; y < h; ++y)
    for (std::size_t x = 0; x < w; ++x) {
      const float gx = (at(x, 1, y, -1) + 2.0f * at(x, 1, y, 0) + at(x, 1, y, 1)) -
                       (at(x, -1, y, -1) + 2.0f * at(x, -1, y, 0) + at(x, -1, y, 1));
      const float gy = (at(x, -1, y, 1) + 2.0f * at(x, 0, y, 1) + at(x, 1, y, 1)) -
                       (at(x, -1, y, -1) + 2.0f * at(x, 0, y, -1) + at(x, 1, y, -1));
      mag[y * w + x] = std::sqrt(gx * gx + gy * gy);
    }
  return mag;
}

std::vector<Index> top_fraction_features(std::span<const float> magnitude, double fraction) {
  if (!(fraction > 0.0 && fraction <= 1.0)) throw InvalidInput("top_fraction_features: fraction must be in (0, 1]");
  std::vector<Index> out;
  if (magnitude.empty()) return out;
  for (std::size_t i = 0; i < magnitude.size(); ++i)
    if (std::isnan(magnitude[i]))  // nth_element needs an order: a NaN left the threshold undefined
      throw InvalidInput("top_fraction_features: magnitude " + std::to_string(i) + " is NaN");
  std::vector<float> sorted(magnitude.begin(), magnitude.end());
  const auto k = static_cast<std::size_t>(std::ceil(fraction * static_cast<double>(sorted.size())));
  const std::size_t kth = std::clamp<std::size_t>(k, 1, sorted.size()) - 1;
  std::nth_element(sorted.begin(), sorted.begin() + static_cast<std::ptrdiff_t>(kth), sorted.end(), std::greater<float>());
  const float threshold = sorted[kth];
  for (std::size_t i = 0; i < magnitude.size(); ++i)
    if (magnitude[i] >= threshold && magnitude[i] > 0.0f) out.push_back(static_cast<Index>(i));
  return out;
}

TriMesh image_grid_mesh(const Image& image) {
  check_image(image, "image_grid_mesh");
  if (image.width < 2 || image.height < 2) throw InvalidInput("image_grid_mesh: the image must be at least 2 x 2 pixels");
  TriMesh m;
  m.positions.reserve(image.width * image.height);
  m.colors.reserve(image.width * image.height);
  for (std::size_t y = 0; y < image.height; ++y)
    for (std::size_t x = 0; x < image.width; ++x) {
      m.positions.push_back({static_cast<float>(x), static_cast<float>(image.height - 1 - y), 0.0f});
      m.colors.push_back(pixel_rgb(image, x, y));
    }
  grid_faces(image.width, image.height, true, m.indices);
  return m;
}

TriMesh heightfield_grid_mesh(const HeightField& field) {
  field.validate();
  if (field.width < 2 || field.height < 2) throw InvalidInput("heightfield_grid_mesh: the field must be at least 2 x 2 samples");
  TriMesh m;
  m.positions.reserve(field.width * field.height);
  for (std::size_t y = 0; y < field.height; ++y)
    for (std::size_t x = 0; x < field.width; ++x) m.positions.push_back(field.to_world(x, y));
  grid_faces(field.width, field.height, false, m.indices);
  return m;
}

Image make_feature_test_image(std::size_t size) {
  if (size < 8) throw InvalidInput("make_feature_test_image: size must be >= 8");
  Image img;
  img.width = img.height = size;
  img.channels = 1;
  img.bit_depth = 8;
  img.pixels.resize(size * size);
  const float s = static_cast<float>(size);
  for (std::size_t y = 0; y < size; ++y)
    for (std::size_t x = 0; x < size; ++x) {
      const float u = (static_cast<float>(x) + 0.5f) / s, v = (static_cast<float>(y) + 0.5f) / s;
      float g = 0.25f + 0.35f * (u + v) * 0.5f;  // smooth background: no features
      auto disc = [&](float cx, float cy, float r) { return (u - cx) * (u - cx) + (v - cy) * (v - cy) <= r * r; };
      if (disc(0.3f, 0.3f, 0.17f)) g = 0.9f;
      if (disc(0.72f, 0.35f, 0.12f)) g = 0.05f;
      if (disc(0.62f, 0.72f, 0.2f) && !disc(0.62f, 0.72f, 0.12f)) g = 0.75f;
      if (u > 0.12f && u < 0.32f && v > 0.62f && v < 0.86f) g = 0.1f;
      img.pixels[y * size + x] = static_cast<std::uint8_t>(std::lround(std::clamp(g, 0.0f, 1.0f) * 255.0f));
    }
  return img;
}

}  // namespace varmesh
