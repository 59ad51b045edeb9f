#pragma once
// A minimal reader of zip archives as torch.save writes them: entries stored uncompressed (method 0),
// zip64 extensions honoured. Compressed entries are refused with a clear error (torch.save never
// compresses; a re-zipped checkpoint must be re-saved). Every offset is checked against the file size.
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "lrf/core/byte_source.h"

namespace lrf {

class ZipReader {
 public:
  struct Entry {
    std::string name;
    std::uint64_t size = 0;         // uncompressed size
    std::uint64_t header_offset = 0;  // local header offset
    std::uint16_t method = 0;
  };

  // Throws lrf::Error if the file is not a zip archive.
  explicit ZipReader(const std::string& path);
  // Same, over any byte source (e.g. a MemorySource over bytes already in memory); path() is its name.
  explicit ZipReader(std::unique_ptr<ByteSource> source);
  const std::vector<Entry>& entries() const { return entries_; }
  const Entry* find(const std::string& name) const;
  // Copies an entry's bytes into dst, which must hold entry.size bytes.
  void read(const Entry& entry, void* dst);
  std::string read(const Entry& entry);
  const std::string& path() const { return path_; }

 private:
  std::uint64_t data_offset(const Entry& entry);
  std::string path_;
  std::unique_ptr<ByteSource> src_;
  std::vector<Entry> entries_;
};

// True if the file starts with a zip local-file-header signature.
bool looks_like_zip(const std::string& path);

}  // namespace lrf
