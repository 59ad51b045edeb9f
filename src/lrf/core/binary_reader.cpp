#include "lrf/core/binary_reader.h"

namespace lrf {

void BinaryReader::require(size_t n, const char* what) const {
  if (n > remaining()) {
    fail(path_, "truncated file: needs " + std::to_string(n) + " more bytes for a " + what + " at offset " +
                    std::to_string(pos_) + ", file has " + std::to_string(bytes_.size()));
  }
}

std::string BinaryReader::read_cstring() {
  size_t end = bytes_.find('\0', pos_);
  if (end == std::string::npos) fail(path_, "truncated file: unterminated string at offset " + std::to_string(pos_));
  std::string s = bytes_.substr(pos_, end - pos_);
  pos_ = end + 1;
  return s;
}

void BinaryReader::require_records(uint64_t count, uint64_t min_record_bytes, const char* what) const {
  if (min_record_bytes > 0 && count > remaining() / min_record_bytes) {
    fail(path_, "truncated or corrupt file: claims " + std::to_string(count) + " " + what + " but only " +
                    std::to_string(remaining()) + " bytes remain");
  }
}

}  // namespace lrf
