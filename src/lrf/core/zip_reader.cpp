#include "lrf/core/zip_reader.h"

#include <algorithm>
#include <fstream>

#include "lrf/core/error.h"

namespace lrf {
namespace {

constexpr std::uint32_t kLocalSig = 0x04034b50;
constexpr std::uint32_t kCentralSig = 0x02014b50;
constexpr std::uint32_t kEndSig = 0x06054b50;
constexpr std::uint32_t kEnd64LocatorSig = 0x07064b50;
constexpr std::uint32_t kEnd64Sig = 0x06064b50;
// More entries than this is not a checkpoint (a big model has a few thousand storages).
constexpr std::uint64_t kMaxEntries = 1u << 20;

}  // namespace

ZipReader::ZipReader(const std::string& path) : ZipReader(std::make_unique<FileSource>(path)) {}

ZipReader::ZipReader(std::unique_ptr<ByteSource> source) : path_(source->name()), src_(std::move(source)) {
  const std::string& path = path_;
  const std::uint64_t size = src_->size();
  if (size < 22) fail(path, "not a zip archive (too short to be a PyTorch checkpoint)");
  // The end-of-central-directory record is in the last 22 + 65535 (comment) bytes.
  std::uint64_t tail_len = std::min<std::uint64_t>(size, 22 + 65535);
  std::string tail = src_->read_string(size - tail_len, tail_len);
  auto* t = reinterpret_cast<const unsigned char*>(tail.data());
  std::int64_t eocd = -1;
  for (std::int64_t i = static_cast<std::int64_t>(tail_len) - 22; i >= 0; --i) {
    if (load_le32(t + i) == kEndSig) {
      eocd = i;
      break;
    }
  }
  if (eocd < 0) {
    bool local = false;
    if (size >= 4) {
      unsigned char head[4];
      src_->read(0, head, 4);
      local = load_le32(head) == kLocalSig;
    }
    fail(path, local ? "truncated zip archive: end of central directory not found"
                     : "not a zip archive (expected a PyTorch zip checkpoint or a .safetensors file)");
  }
  const unsigned char* e = t + eocd;
  std::uint64_t count = load_le16(e + 10);
  std::uint64_t cd_size = load_le32(e + 12);
  std::uint64_t cd_offset = load_le32(e + 16);
  const std::uint64_t eocd_abs = size - tail_len + static_cast<std::uint64_t>(eocd);
  if (count == 0xffff || cd_size == 0xffffffffu || cd_offset == 0xffffffffu) {
    // Zip64: a locator sits just before the classic record.
    if (eocd_abs < 20) fail(path, "corrupt zip64 archive");
    unsigned char loc[20];
    src_->read(eocd_abs - 20, loc, 20);
    if (load_le32(loc) != kEnd64LocatorSig) fail(path, "corrupt zip64 archive: locator missing");
    std::uint64_t rec = load_le64(loc + 8);
    unsigned char r[56];
    src_->read(rec, r, 56);
    if (load_le32(r) != kEnd64Sig) fail(path, "corrupt zip64 archive: end record missing");
    count = load_le64(r + 32);
    cd_size = load_le64(r + 40);
    cd_offset = load_le64(r + 48);
  }
  if (count > kMaxEntries) fail(path, "zip archive claims " + std::to_string(count) + " entries");
  std::string cd = src_->read_string(cd_offset, cd_size);
  auto* c = reinterpret_cast<const unsigned char*>(cd.data());
  std::uint64_t pos = 0;
  for (std::uint64_t i = 0; i < count; ++i) {
    if (cd_size - pos < 46 || load_le32(c + pos) != kCentralSig) fail(path, "corrupt zip central directory");
    Entry entry;
    entry.method = load_le16(c + pos + 10);
    std::uint64_t csize = load_le32(c + pos + 20);
    entry.size = load_le32(c + pos + 24);
    std::uint64_t name_len = load_le16(c + pos + 28);
    std::uint64_t extra_len = load_le16(c + pos + 30);
    std::uint64_t comment_len = load_le16(c + pos + 32);
    entry.header_offset = load_le32(c + pos + 42);
    if (cd_size - pos - 46 < name_len + extra_len + comment_len) fail(path, "corrupt zip central directory");
    entry.name.assign(cd.data() + pos + 46, name_len);
    // Zip64 extra field: 64-bit values replace the saturated 32-bit ones, in this order.
    const unsigned char* x = c + pos + 46 + name_len;
    std::uint64_t xp = 0;
    while (xp + 4 <= extra_len) {
      std::uint16_t id = load_le16(x + xp), len = load_le16(x + xp + 2);
      if (xp + 4 + len > extra_len) break;
      if (id == 0x0001) {
        std::uint64_t q = xp + 4, qend = xp + 4 + len;
        auto take = [&](std::uint64_t& v) {
          if (v == 0xffffffffu && q + 8 <= qend) { v = load_le64(x + q); q += 8; }
        };
        take(entry.size);
        take(csize);
        take(entry.header_offset);
      }
      xp += 4 + len;
    }
    if (entry.method == 0 && csize != entry.size) fail(path, "corrupt zip entry " + entry.name);
    // Bounds every later allocation by the file size: an entry cannot extend past the end of the file.
    if (entry.header_offset > size || csize > size - entry.header_offset || size - entry.header_offset - csize < 30) {
      fail(path, "zip entry '" + entry.name + "' of " + std::to_string(csize) +
                     " bytes extends past the end of the file (truncated or corrupt archive)");
    }
    pos += 46 + name_len + extra_len + comment_len;
    entries_.push_back(std::move(entry));
  }
}

const ZipReader::Entry* ZipReader::find(const std::string& name) const {
  for (const auto& e : entries_)
    if (e.name == name) return &e;
  return nullptr;
}

std::uint64_t ZipReader::data_offset(const Entry& entry) {
  if (entry.method != 0) {
    fail(path_, "zip entry '" + entry.name + "' is compressed (method " + std::to_string(entry.method) +
                    "); only stored entries, as torch.save writes them, are supported: re-save it with torch.save");
  }
  unsigned char h[30];
  src_->read(entry.header_offset, h, 30);
  if (load_le32(h) != kLocalSig) fail(path_, "corrupt zip: bad local header for " + entry.name);
  return entry.header_offset + 30 + load_le16(h + 26) + load_le16(h + 28);
}

void ZipReader::read(const Entry& entry, void* dst) { src_->read(data_offset(entry), dst, entry.size); }

std::string ZipReader::read(const Entry& entry) { return src_->read_string(data_offset(entry), entry.size); }

bool looks_like_zip(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  unsigned char head[4];
  if (!in.read(reinterpret_cast<char*>(head), 4)) return false;
  return load_le32(head) == kLocalSig;
}

}  // namespace lrf
