#pragma once
// A field's frames with detail borrowed from its training photographs (lrf's detail pass): each frame is
// rendered and decoded as usual, then the nearest training photographs are carried into its camera with
// the field's own depth and blended in where they agree with it (detail_blend.h).
#include <memory>
#include <set>

#include "lrf/detail/blend_network.h"
#include "lrf/detail/detail_blend.h"
#include "lrf/detail/detail_calibration.h"
#include "lrf/frames/field_frames.h"

namespace lrf::detail {

class DetailFrames : public FieldFrames {
 public:
  // Throws lrf::Error when `frames` have no depth (a latent NeRF) or its scene has no training views. With
  // options.calibration_views > 0 the decoded weight is chosen here, on that many training views
  // (detail_calibration.h); a field that does best without the photographs then renders as it is.
  DetailFrames(std::unique_ptr<FieldFrames> frames, const DetailOptions& options);

  FieldKind kind() const override { return frames_->kind(); }
  bool latent() const override { return frames_->latent(); }
  bool has_depth() const override { return frames_->has_depth(); }
  const Scene& scene() const override { return frames_->scene(); }
  int size_multiple() const override { return frames_->size_multiple(); }
  std::string describe() const override;
  // timing->detail_ms holds the pass's own time (depth maps, warps, blend).
  cv::Mat render(const Camera& camera, FrameTiming* timing = nullptr) override;
  cv::Mat depth(const Camera& camera) override { return frames_->depth(camera); }

  // Every training view (index into scene().views) a frame has borrowed from so far.
  const std::set<int>& borrowed_views() const { return borrowed_; }
  // Seconds spent loading the borrowed photographs and rendering the field's depth from their cameras (once
  // per view and scene).
  double source_seconds() const { return source_seconds_; }
  // The calibration's scores and winner (no scores when it was not run), the training views it used and
  // its seconds.
  const DetailCalibration& calibration() const { return calibration_; }
  const std::vector<int>& calibration_views() const { return calibration_views_; }
  double calibration_seconds() const { return calibration_seconds_; }
  // The decoded weight frames are blended with (infinity: the photographs are not used).
  double decoded_weight() const { return options_.decoded_weight; }
  // With options.learned_blend: how the learned blend did on held-out training views, and whether it is used.
  const BlendNetworkReport& network_report() const { return network_report_; }

 private:
  struct Source {
    cv::Mat image;  // CV_32FC3 at the view's camera
    cv::Mat depth;  // the field's depth from that camera
  };
  const Source& source(int view);
  // The decoded frame for `camera` and its nearest training photographs (never view `except`) carried into it.
  struct Inputs {
    cv::Mat decoded;  // CV_32FC3
    std::vector<WarpedView> warped;
  };
  Inputs inputs(const Camera& camera, int except, FrameTiming* timing);
  void calibrate();
  void log_calibration(int count) const;

  std::unique_ptr<FieldFrames> frames_;
  DetailOptions options_;
  std::vector<std::unique_ptr<Source>> sources_;  // by view index, loaded on first use
  std::set<int> borrowed_;
  double source_seconds_ = 0;
  DetailCalibration calibration_;
  std::vector<int> calibration_views_;
  double calibration_seconds_ = 0;
  std::unique_ptr<BlendNetwork> network_;
  BlendNetworkReport network_report_;
};

}  // namespace lrf::detail
