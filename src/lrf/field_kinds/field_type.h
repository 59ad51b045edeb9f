#pragma once
// What a kind of trained field does, behind one interface: its training and the resumption of a run,
// whether its folder holds a finished run, where its checkpoint is, its frames for any camera, its scores on
// the test views, and its renders of the scene's views. One implementation per kind (rgb, latent — feature fields and refined fields included —,
// latent-nerf), looked up once from a folder's config.json; callers ask the field instead of comparing kinds.
#include <memory>
#include <string>

#include <nlohmann/json.hpp>

#include "lrf/field_kinds/field_train_request.h"
#include "lrf/frames/field_frames.h"
#include "lrf/splat/run/field_kind.h"

namespace lrf {

// How `lrf eval` and compare's rows score a field.
struct FieldScoring {
  std::string decoder;        // decoded kinds: a decoder in place of the run's own ("": its own)
  std::string lpips_weights;  // "": LPIPS not computed
  double scale = 1.0;         // RGB fields: score at this multiple of the training resolution
};

// `lrf render`'s images of the scene's views.
struct ViewRenders {
  std::string split = "test";  // test, train or all
  std::string dir;             // "": RUN/renders/SPLIT
  double scale = 1.0;          // RGB fields: this multiple of the training resolution, or
  int width = 0, height = 0;   //   this size (both given)
  std::string decoder;         // decoded kinds: a decoder in place of the run's own
};

class FieldType {
 public:
  virtual ~FieldType() = default;
  virtual FieldKind kind() const = 0;
  // Frames are decoded from rendered latents by an autoencoder's decoder (a decoder can be given).
  virtual bool decoded() const = 0;
  // Fits a field of this kind as `lrf train` asks; throws lrf::UsageError for another kind's settings.
  virtual void train(const FieldTrainRequest& request) const = 0;
  // Continues the run in request.given.out from its checkpoint with its recorded settings.
  virtual void resume(const ResumeRequest& request) const = 0;
  // The checkpoint a resumed run continues from.
  virtual std::string checkpoint_path(const std::string& run) const = 0;
  // The run finished (its field and its record of the result are written).
  virtual bool finished(const std::string& run) const = 0;
  // The field's frames for any camera; throws lrf::Error naming the file on a bad folder, and refuses a
  // decoder for a kind that has none.
  virtual std::unique_ptr<FieldFrames> frames(const std::string& run, const std::string& decoder) const = 0;
  // Scores the test views: RUN/metrics.json and RUN/eval/*.png, as lrf eval and compare's rows write them.
  // Throws lrf::UsageError for a setting the kind does not take.
  virtual nlohmann::json evaluate(const std::string& run, const FieldScoring& scoring) const = 0;
  // Writes the views' images (decoded kinds: their rendered latents too) and returns how many.
  virtual int render_views(const std::string& run, const ViewRenders& request) const = 0;
};

// The implementation of `kind`.
const FieldType& field_type(FieldKind kind);
// The kind of field in folder `run`, from its config.json; throws lrf::Error naming the file when it is
// missing, unreadable or names an unknown kind.
const FieldType& field_type_of(const std::string& run);

// The frames of the field in `run` (field_type_of(run).frames): what render --path, serve, the detail pass
// and the demo show.
std::unique_ptr<FieldFrames> open_field_frames(const std::string& run, const std::string& decoder = "");

}  // namespace lrf
