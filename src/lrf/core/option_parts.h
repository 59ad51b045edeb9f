#pragma once
// Job options are built from shared parts, each a base of the records that have it (RunControl,
// LatentSource, SceneFitOptions, ...). A caller that starts one job from another's options copies a part
// whole, so that a setting added to the part needs no new line in any caller.
namespace lrf {

template <class Part, class To, class From>
void copy_part(To& to, const From& from) {
  static_cast<Part&>(to) = static_cast<const Part&>(from);
}

}  // namespace lrf
