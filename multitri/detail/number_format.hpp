#pragma once
/// Appending numbers to an output buffer for the text writers. Floats use std::to_chars' shortest form,
/// which parses back (std::from_chars into float) to the identical bit pattern.
#include <charconv>
#include <cstdint>
#include <string>

#include "multitri/tri_mesh.hpp"

namespace varmesh::detail {

inline void append_float(std::string& out, float v) {
  char buf[32];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  out.append(buf, r.ptr);
}

/// Like append_float, but the text always reads as a float literal ("1.0", not "1"): OFF colours are
/// integers 0..255 or floats 0..1, told apart by their spelling.
inline void append_float_literal(std::string& out, float v) {
  char buf[32];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  out.append(buf, r.ptr);
  for (const char* c = buf; c != r.ptr; ++c)
    if (*c == '.' || *c == 'e' || *c == 'E') return;
  out += ".0";
}

inline void append_uint(std::string& out, std::uint64_t v) {
  char buf[24];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  out.append(buf, r.ptr);
}

/// Appends "x y z" (shortest round-trip floats, single spaces).
inline void append_vec3(std::string& out, const glm::vec3& v) {
  append_float(out, v.x);
  out += ' ';
  append_float(out, v.y);
  out += ' ';
  append_float(out, v.z);
}

/// Saturating arithmetic for the readers' "does the file hold that many elements" checks.
inline std::uint64_t sat_mul(std::uint64_t a, std::uint64_t b) {
  std::uint64_t r;
  return __builtin_mul_overflow(a, b, &r) ? UINT64_MAX : r;
}
inline std::uint64_t sat_add(std::uint64_t a, std::uint64_t b) {
  std::uint64_t r;
  return __builtin_add_overflow(a, b, &r) ? UINT64_MAX : r;
}

/// One line "3 a b c" per face: the face list shared by OFF and ascii PLY.
inline void append_triangle_lines(std::string& out, const TriMesh& mesh) {
  for (std::size_t f = 0; f < mesh.num_faces(); ++f) {
    out += "3 ";
    append_uint(out, mesh.corner(f, 0));
    out += ' ';
    append_uint(out, mesh.corner(f, 1));
    out += ' ';
    append_uint(out, mesh.corner(f, 2));
    out += '\n';
  }
}

}  // namespace varmesh::detail
