#pragma once
// A salience map that picks the next fixation target: Itti and Koch's (2000) model as the course
// notes build it on the Owl ("Itti & Koch's Salience Model using the OWL", Figs. 24-25, and Code
// Snippet 7): three feature channels, each a centre-surround difference of Gaussians (DoG),
// normalised and summed, then the strongest points picked one after the other with inhibition
// of return.
//
// Channels (computed on the image shrunk once with pyrDown, as the notes suggest: "create an image
// pyramid of sub-sampled filtered products using pyrDown", so a 640x480 eye gives a 320x240 map):
//   intensity    |G_inner * I - G_outer * I|, I the grey level in [0, 1]: the notes' DoG
//                (Snippet 7: Gaussian kernels of 9 and 9 x 5 = 45 px) on the shrunk image, i.e. twice
//                that reach at full size: tuned to blobs of about 5-15 px radius (a 24 mm disc at
//                0.5-1.5 m); with the kernels at full size it answers edges and corners instead;
//   colour       the same DoG on the HSV saturation S in [0, 1] (the notes' Fig. 24: "Convert RGB to
//                HSV and extract ... the S matrix"); zero on a grey image;
//   orientation  Gabor energy at 0, 45, 90 and 135 deg (wavelength 6 px of the shrunk image), each
//                through the same centre-surround DoG (kept where positive), the four summed after
//                normalisation.
// Normalisation N(.) (Itti, Koch and Niebur 1998): a channel is scaled to [0, 1] by its maximum
// and multiplied by (1 - m)^2, m the mean of its other local maxima above 0.05: a channel with one
// strong peak keeps its weight, one with many similar peaks (texture, noise) is damped. A channel
// whose maximum is below min_channel (no feature at all) is zero. The map is the weighted mean of
// the normalised channels, in [0, 1].
//
// Candidates: the map's maximum (refined to sub-pixel by a parabola in x and y), then the map is
// cleared within inhibition_radius_px of it (inhibition of return) and the next maximum taken,
// until num_candidates are found or the next is weaker than min_score_fraction of the first.
// Pixels are full-image pixels in OpenCV's convention (docs/conventions.md).
//
// Usage:
//   calib::SalienceMap m = calib::ComputeSalience(right_eye_bgr, {});
//   if (!m.candidates.empty()) next_target_px = m.candidates[0].px;
#include <string>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

namespace owlcal::calib {

struct SalienceOptions {
  int dog_inner_px = 9;   // Gaussian kernel sizes (odd) on the shrunk image (Code Snippet 7: g = 9,
  int dog_outer_px = 45;  //   k = 5)
  double intensity_weight = 1, colour_weight = 1, orientation_weight = 1;
  double min_channel = 0.02;  // channel maxima below this (in [0, 1] feature units) are no feature
  int num_candidates = 5;
  double inhibition_radius_px = 40;  // full-image pixels
  double min_score_fraction = 0.2;   // of the first candidate's score
  int border_px = 16;                // no candidate closer to the image border

  bool Check(std::string* why) const;
};

struct SalienceCandidate {
  Eigen::Vector2d px = Eigen::Vector2d::Zero();  // full-image pixel
  double score = 0;                              // the map's value there, in [0, 1]
  // The normalised channels' values at the candidate (what made it salient).
  double intensity = 0, colour = 0, orientation = 0;
};

struct SalienceMap {
  cv::Mat map;  // CV_32F, the shrunk image's size; map(y, x) belongs to full pixel (scale x, scale y)
  cv::Mat intensity, colour, orientation;     // the normalised channels, same size
  double scale = 2;                           // full-image pixels per map pixel
  std::vector<SalienceCandidate> candidates;  // ranked, strongest first
};

// Throws std::invalid_argument for an empty image or options that fail Check.
SalienceMap ComputeSalience(const cv::Mat& image, const SalienceOptions& options);

}  // namespace owlcal::calib
