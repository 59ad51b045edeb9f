#pragma once
// The viewer page's files (src/lrf/viewer/assets/), compiled into the binary by cmake/embed_assets.cmake
// so that `lrf serve` needs nothing beside it and serves nothing but these.
#include <cstddef>
#include <string>
#include <vector>

namespace lrf::viewer {

struct Asset {
  const char* name;  // file name, e.g. "viewer.js"
  const unsigned char* data;
  size_t size;
};

const std::vector<Asset>& viewer_assets();
// "text/html; charset=utf-8" etc. by the name's extension.
std::string asset_content_type(const std::string& name);

}  // namespace lrf::viewer
