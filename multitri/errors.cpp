#include "multitri/errors.hpp"

#include <sstream>

namespace varmesh {
namespace {

std::string io_message(const std::string& file, const std::string& reason, std::size_t line,
                       std::uint64_t offset) {
  std::ostringstream out;
  out << file;
  if (line != IoError::kNoLine) out << ':' << line;
  if (offset != IoError::kNoOffset) out << " (byte " << offset << ')';
  out << ": " << reason;
  return out.str();
}

}  // namespace

IoError::IoError(std::string file, std::string reason, std::size_t line, std::uint64_t byte_offset)
    : std::runtime_error(io_message(file, reason, line, byte_offset)),
      file_(std::move(file)),
      reason_(std::move(reason)),
      line_(line),
      byte_offset_(byte_offset) {}

InvalidInput::InvalidInput(std::string reason, std::uint64_t element)
    : std::invalid_argument(element == kNoElement ? reason
                                                  : reason + " (element " + std::to_string(element) + ")"),
      element_(element) {}

}  // namespace varmesh
