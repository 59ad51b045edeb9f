#pragma once
// Bounds-checked little-endian reads from an in-memory file. Every read checks the remaining length, so a
// truncated or corrupt file gives an error naming the file and the offset instead of a crash, and counts
// read from the file can be checked against the bytes left before anything is allocated.
#include <cstdint>
#include <cstring>
#include <string>

#include "lrf/core/error.h"

namespace lrf {

class BinaryReader {
 public:
  BinaryReader(std::string bytes, std::string path) : bytes_(std::move(bytes)), path_(std::move(path)) {}

  template <typename T>
  T read() {
    require(sizeof(T), "value");
    T v;
    std::memcpy(&v, bytes_.data() + pos_, sizeof(T));
    pos_ += sizeof(T);
    return v;
  }
  // Reads a NUL-terminated string (COLMAP image names).
  std::string read_cstring();
  // Checks that `count` records of at least `min_record_bytes` each can still be in the file.
  void require_records(uint64_t count, uint64_t min_record_bytes, const char* what) const;
  size_t remaining() const { return bytes_.size() - pos_; }
  size_t position() const { return pos_; }
  const std::string& path() const { return path_; }

 private:
  void require(size_t n, const char* what) const;
  std::string bytes_;
  std::string path_;
  size_t pos_ = 0;
};

}  // namespace lrf
