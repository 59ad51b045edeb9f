#pragma once
// Keys of the on-disk caches (encoded latents, triangulated points): a cache entry is named by a stable
// hash of a text key that lists everything the entry depends on, and stores that text so that a hash
// collision or an edited file is noticed. Inputs are identified by path, size and modification time;
// weights by their content.
#include <cstdint>
#include <string>

namespace lrf {

// $LRF_CACHE, else $XDG_CACHE_HOME/lrf, else ~/.cache/lrf, else ./.lrf-cache.
std::string default_cache_dir();

// FNV-1a: a 64-bit hash that is the same across builds and runs (std::hash promises neither).
uint64_t fnv1a64(const std::string& text);
// The hash as 16 lower-case hex digits (a cache file's name).
std::string hash_hex(const std::string& text);

// "absolute-path:size:mtime" of a file (size and mtime 0 when it cannot be read).
std::string file_stamp(const std::string& path);

// "file-name:size:FNV-1a of the bytes": weights are named by their content, not their path or time, so
// that a copy or a fresh download of the same file keeps every run and cache made with it valid, and an
// edited file of the same size does not. Fails naming the file when it cannot be read.
std::string content_stamp(const std::string& path);

}  // namespace lrf
