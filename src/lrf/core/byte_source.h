#pragma once
// Random-access reads from a file or from memory, with every read bounds-checked. Weight readers use it
// so that a lying length field in an untrusted file becomes an error, never a huge allocation or an
// out-of-bounds read.
#include <cstdint>
#include <fstream>
#include <string>

namespace lrf {

class ByteSource {
 public:
  virtual ~ByteSource() = default;
  virtual std::uint64_t size() const = 0;
  // Copies n bytes at `offset` into dst; throws lrf::Error (naming the source) past the end.
  virtual void read(std::uint64_t offset, void* dst, std::uint64_t n) = 0;
  std::string read_string(std::uint64_t offset, std::uint64_t n);
  const std::string& name() const { return name_; }

 protected:
  explicit ByteSource(std::string name) : name_(std::move(name)) {}
  void check_range(std::uint64_t offset, std::uint64_t n) const;

 private:
  std::string name_;
};

class FileSource : public ByteSource {
 public:
  explicit FileSource(const std::string& path);
  std::uint64_t size() const override { return size_; }
  void read(std::uint64_t offset, void* dst, std::uint64_t n) override;

 private:
  std::ifstream in_;
  std::uint64_t size_ = 0;
};

class MemorySource : public ByteSource {
 public:
  // Keeps a reference: `bytes` must outlive the source.
  MemorySource(const std::string& bytes, std::string name) : ByteSource(std::move(name)), bytes_(bytes) {}
  std::uint64_t size() const override { return bytes_.size(); }
  void read(std::uint64_t offset, void* dst, std::uint64_t n) override;

 private:
  const std::string& bytes_;
};

// Little-endian integer decoding from raw bytes.
std::uint16_t load_le16(const unsigned char* p);
std::uint32_t load_le32(const unsigned char* p);
std::uint64_t load_le64(const unsigned char* p);

}  // namespace lrf
