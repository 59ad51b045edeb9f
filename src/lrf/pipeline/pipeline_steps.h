#pragma once
// The pipeline's artefacts, each made by one function that reuses a finished one made with the same
// settings (and refuses one made with others, naming what differs), resumes an interrupted one from its
// checkpoint, or makes it: Stage I's encoder, the latent and RGB fields, the refined fields, Stage III's
// decoders, and the scores of every row.
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "lrf/pipeline/pipeline_jobs.h"

namespace lrf {

// A latent field (the Stage II job `job`) of `scene` at `resolution` (train_views > 0: a K-view split) on
// `encoder`'s latents ("": stock).
void ensure_latent_field(const LatentTrainOptions& job, const std::string& scene, const SceneResolution& resolution,
                         int train_views, const std::string& dir, const std::string& encoder);

// An RGB baseline's field (the baselines' job `job`, at the evaluation protocol's views).
void ensure_rgb_field(const RgbTrainOptions& job, const std::string& scene, const SceneResolution& resolution,
                      const std::string& dir, const RgbBaseline& baseline);
// An RGB baseline's scores (its metrics.json when it holds every metric, else scored now).
nlohmann::json ensure_rgb_eval(const FieldScoring& scoring, const std::string& dir);

// A field refined (the refinement job `job`) through `decoder` (refine_folder.h: reused, continued to more
// steps, resumed or made).
void refine_eval_field(const RefineOptions& job, const std::string& field, const std::string& decoder,
                       const std::string& dir);

// True if Stage I finished with these options; throws if it finished with others.
bool encoder_finished(const EncoderFinetuneOptions& e);
void ensure_encoder(const EncoderFinetuneOptions& e);

// The Stage III job `job` on `fields` (latent fields of `encoder`'s latents, "": stock), written to `out`.
DecoderFinetuneOptions decoder_options(const DecoderFinetuneOptions& job, const std::vector<std::string>& fields,
                                       const std::string& encoder, const std::string& out);
// True if this Stage III decoder finished with these options; throws if it finished with others.
bool decoder_finished(const DecoderFinetuneOptions& d);
void ensure_decoder(const DecoderFinetuneOptions& d);

// A latent row: `field` decoded by `decoder` ("": the one it records), scored into `dir`.
nlohmann::json ensure_latent_eval(const FieldScoring& scoring, const std::string& field, const std::string& decoder,
                                  const std::string& dir);
// The detail pass's row of a refined field; `field_scores` (the field's own row) gives what the pass
// leaves as it was: the latent and round-trip PSNR, the training time and storage.
nlohmann::json ensure_detail_eval(const detail::DetailEvalOptions& scoring, const std::string& field,
                                  const std::string& dir, const nlohmann::json& field_scores);

// The scenes a Stage III decoder was fine-tuned on, from its fields' recorded configurations.
std::vector<std::string> field_scenes(const std::vector<std::string>& fields);

}  // namespace lrf
