#include "lrf/core/byte_source.h"

#include <cstring>
#include <filesystem>

#include "lrf/core/error.h"

namespace lrf {

std::string ByteSource::read_string(std::uint64_t offset, std::uint64_t n) {
  check_range(offset, n);
  std::string s(static_cast<std::size_t>(n), '\0');
  if (n > 0) read(offset, s.data(), n);
  return s;
}

void ByteSource::check_range(std::uint64_t offset, std::uint64_t n) const {
  // Written to avoid overflow in offset + n.
  if (offset > size() || n > size() - offset) {
    fail(name_, "truncated or corrupt: needs bytes " + std::to_string(offset) + ".." +
                    std::to_string(offset) + "+" + std::to_string(n) + " but the data has " +
                    std::to_string(size()) + " bytes");
  }
}

FileSource::FileSource(const std::string& path) : ByteSource(path) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) fail(path, "file not found");
  size_ = std::filesystem::file_size(path, ec);
  if (ec) fail(path, "cannot read size: " + ec.message());
  in_.open(path, std::ios::binary);
  if (!in_) fail(path, "cannot open for reading");
}

void FileSource::read(std::uint64_t offset, void* dst, std::uint64_t n) {
  check_range(offset, n);
  in_.clear();
  in_.seekg(static_cast<std::streamoff>(offset));
  in_.read(static_cast<char*>(dst), static_cast<std::streamsize>(n));
  if (!in_ || static_cast<std::uint64_t>(in_.gcount()) != n) fail(name(), "read error");
}

void MemorySource::read(std::uint64_t offset, void* dst, std::uint64_t n) {
  check_range(offset, n);
  if (n > 0) std::memcpy(dst, bytes_.data() + offset, static_cast<std::size_t>(n));
}

std::uint16_t load_le16(const unsigned char* p) { return static_cast<std::uint16_t>(p[0] | (p[1] << 8)); }
std::uint32_t load_le32(const unsigned char* p) {
  return static_cast<std::uint32_t>(p[0]) | (static_cast<std::uint32_t>(p[1]) << 8) |
         (static_cast<std::uint32_t>(p[2]) << 16) | (static_cast<std::uint32_t>(p[3]) << 24);
}
std::uint64_t load_le64(const unsigned char* p) {
  return static_cast<std::uint64_t>(load_le32(p)) | (static_cast<std::uint64_t>(load_le32(p + 4)) << 32);
}

}  // namespace lrf
