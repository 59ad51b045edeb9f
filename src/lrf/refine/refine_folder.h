#pragma once
// Reuse of a refined field by the commands that make one as one of their steps (compare's latent-refined
// row, pipeline's +refine rows): a finished refinement is only reused if it was made with the options
// asked for now, so that a row never passes for one made with other settings (e.g. after a default
// changed).
#include <string>

#include "lrf/refine/refine.h"

namespace lrf {

// Brings `r.out` to a finished refinement of `r.run` with options `r`:
// - with `start_over` (e.g. `r.run` was just made again, or the user asked to recompute), it refines from
//   the start whatever the folder holds;
// - a finished one made with the same options is reused (returns false: nothing was run);
// - a finished one with the same options but fewer steps, at constant rates (lr_final 1), is continued
//   to r.steps, which gives the field a run of r.steps from the start would have;
// - an interrupted one is resumed (refine_latent_field refuses it if its options differ);
// - otherwise the refinement starts afresh.
// A finished refinement made with other options, or with more steps, is refused with an error naming
// each differing setting, `what` (e.g. "the refined field") and `remedy` (what the user can do).
// r.resume and r.force are set here.
bool ensure_refined_field(RefineOptions r, const std::string& what, const std::string& remedy, bool start_over);

}  // namespace lrf
