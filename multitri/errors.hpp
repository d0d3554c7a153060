#pragma once
/// Typed errors thrown by the library. The library never prints or aborts on bad input: it throws one of
/// these, and the command-line tool prints `what()` on one line.
///
/// - IoError: a file could not be read or written, or its content is malformed. Carries the file name and,
///   when known, the 1-based line number (text formats) or the byte offset (binary formats).
/// - InvalidInput: arrays or parameters handed to a public function break its contract. Carries the index
///   of the offending element when there is one. In multitri this includes the validate() self-checks
///   (Mt::validate, MtFront::validate, TriMesh::validate, ...), which name the element that breaks an
///   invariant.
/// - std::logic_error (other than InvalidInput, which derives from it through std::invalid_argument): an
///   internal invariant of the library is broken, i.e. a bug, not bad input. Some validate() functions
///   and internal guards of the other modules report this way (pm's VertexHierarchy::validate, fourk's
///   refinement guards); their headers say so.
/// - std::bad_alloc when memory runs out.
///
/// Unchecked accessors (noexcept, O(1), taking an element id, as std::vector::operator[] takes an index)
/// state their precondition in their comment instead of throwing; VARMESH_ASSERT (detail/assert.hpp)
/// checks it in debug and sanitizer builds.
#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>

namespace varmesh {

class IoError : public std::runtime_error {
 public:
  static constexpr std::size_t kNoLine = 0;
  static constexpr std::uint64_t kNoOffset = UINT64_MAX;

  /// `line` is 1-based (0 = unknown); `byte_offset` is from the start of the file (kNoOffset = unknown).
  IoError(std::string file, std::string reason, std::size_t line = kNoLine,
          std::uint64_t byte_offset = kNoOffset);

  const std::string& file() const noexcept { return file_; }
  const std::string& reason() const noexcept { return reason_; }
  std::size_t line() const noexcept { return line_; }
  std::uint64_t byte_offset() const noexcept { return byte_offset_; }

 private:
  std::string file_;
  std::string reason_;
  std::size_t line_;
  std::uint64_t byte_offset_;
};

class InvalidInput : public std::invalid_argument {
 public:
  static constexpr std::uint64_t kNoElement = UINT64_MAX;

  /// `element` is the index of the offending element (vertex, face, node, ...), kNoElement if none.
  explicit InvalidInput(std::string reason, std::uint64_t element = kNoElement);

  std::uint64_t element() const noexcept { return element_; }

 private:
  std::uint64_t element_;
};

}  // namespace varmesh
