#pragma once
/// Basic index types shared by every varmesh module.
///
/// All relations are 32-bit indices into contiguous arrays (DESIGN.md, "Storage habits"); kInvalid marks
/// "none". Strong id types are deliberately thin: they hold an index and nothing else.
#include <cstdint>
#include <limits>

namespace varmesh {

using Index = std::uint32_t;
inline constexpr Index kInvalid = std::numeric_limits<Index>::max();

/// Node of a Multi-Triangulation DAG. Node 0 is the source; nodes are numbered parents first.
using NodeId = Index;
/// Face (triangle) of a mesh or of a Multi-Triangulation.
using FaceId = Index;
/// Vertex of a mesh or of a Multi-Triangulation.
using VertexId = Index;

/// 64-bit key of the directed edge a -> b (a in the high half): equal keys, same directed edge.
constexpr std::uint64_t directed_edge_key(Index a, Index b) noexcept { return (std::uint64_t{a} << 32) | b; }
/// 64-bit key of the undirected edge {a, b}: the directed key from its smaller end.
constexpr std::uint64_t undirected_edge_key(Index a, Index b) noexcept {
  return a < b ? directed_edge_key(a, b) : directed_edge_key(b, a);
}

}  // namespace varmesh
