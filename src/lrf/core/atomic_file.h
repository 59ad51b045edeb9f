#pragma once
// Crash-safe writes: results go to a temporary file in the same folder, are flushed to disk, and are
// renamed over the target, so a reader sees either the old file or the complete new one, never a part.
#include <functional>
#include <string>

namespace lrf {

void write_file_atomic(const std::string& path, const std::string& bytes);
// For writers that need a path (OpenCV, libtorch): `write` writes to the given temporary path, then it
// is fsynced and renamed to `path`. The temporary file is removed if `write` throws.
void write_atomic_with(const std::string& path, const std::function<void(const std::string&)>& write);
// For writers that must choose their own temporary name (FFmpeg picks a container from the extension):
// fsyncs the finished `tmp` and renames it to `path` (removing `tmp` and throwing when that fails).
void move_into_place(const std::string& tmp, const std::string& path);
std::string read_file(const std::string& path);
// Removes the temporaries that writes into `folder` left when their process was killed (NAME.tmpHEX, as
// this file names them), not looking into subfolders. Call it while holding the folder's lock, so that no
// live write's temporary is taken. Returns how many were removed.
int remove_stale_temporaries(const std::string& folder);

}  // namespace lrf
