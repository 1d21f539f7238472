#pragma once
// Bottom-up attention on the retina: a saliency map per level from
// centre-surround contrast across levels, edge energy, motion and (on a
// colour retina) similarity to a wanted colour; and inhibition of return, so
// attention moves on once a place has been looked at.
#include <array>
#include <optional>
#include <vector>

#include <opencv2/core.hpp>

#include "kernels.hpp"
#include "saccade/message.hpp"

namespace saccade::fovea {

struct SaliencyConfig {
  // Weights of the conspicuity maps; each map is first scaled to [0, 1] by its
  // largest value over all levels (or by its floor, when that is larger, so a
  // flat image does not become salient by normalisation).
  double contrast_weight = 1.0;
  double edge_weight = 1.0;
  double motion_weight = 2.0;
  double color_weight = 1.0;
  double contrast_floor = 10.0;    // gray levels
  double edge_floor = 120.0;       // Sobel magnitude
  double motion_floor = 15.0;      // |dI|, gray levels
  std::optional<cv::Vec3d> color;  // wanted colour (B, G, R); needs a BGR retina
  double color_tolerance = 40.0;   // distance at which the colour term falls to exp(-1/2)
  int border = 1;                  // level pixels ignored at each level's edge
  // 0: every map normalised over all levels together; 1: each level alone
  // (see Saliency::compute).
  double level_boost = 0.0;
};

// A place worth looking at: a point in source pixels, its saliency and the
// level it was found on.
struct Candidate {
  cv::Point2d point{-1, -1};
  double value = 0.0;
  int level = -1;
  bool valid() const { return level >= 0; }
};

// Places recently looked at, each inhibiting a disc that fades linearly over
// `frames`. Fixed capacity: the oldest place is forgotten first, and nothing is
// allocated after construction.
class InhibitionOfReturn {
 public:
  InhibitionOfReturn(double radius, int frames);
  void add(cv::Point2d point, double strength = 1.0);
  void tick();                     // one frame has passed
  void shift(cv::Point2d offset);  // the scene moved in the image by `offset` (the head turned)
  void clear();
  // 0 (free) .. 1 (fully inhibited) at `point`.
  double at(cv::Point2d point) const;
  std::size_t size() const { return count_; }

 private:
  struct Place {
    cv::Point2d point;
    double strength = 0.0;
    int age = 0;
  };
  static constexpr std::size_t kCapacity = 32;
  std::array<Place, kCapacity> places_{};
  std::size_t count_ = 0, next_ = 0;
  double radius_;
  int frames_;
};

class Saliency {
 public:
  explicit Saliency(SaliencyConfig config);
  // `motion_dI`: the motion node's dI per level on this retina's geometry, or
  // nullptr. Allocates only when the retina's shape changes.
  void compute(const Retina& retina, const std::vector<cv::Mat>* motion_dI);
  // Saliency per level (CV_32F, same size as the levels).
  const std::vector<cv::Mat>& maps() const { return maps_; }
  // The most salient place after inhibition, over every level; with `moving`
  // only places whose |dI| reaches the motion floor.
  Candidate peak(const InhibitionOfReturn& ior, bool moving = false) const;
  // The most salient place on one level, at least `margin` level pixels from
  // its edges.
  Candidate peak_on_level(int level, int margin_x, int margin_y) const;
  // The centre of the object around `seed` on one level: the centroid, weighted
  // by appearance saliency (contrast and edges, not motion, which marks an
  // object's moving edges rather than its extent), of the 4-connected pixels
  // above `fraction` of the strongest value next to the seed. Where a compact
  // object is, this is its centre rather than its most salient corner.
  // `cut` (when given) tells whether the blob reaches the level's edge, where
  // the centre is biased towards the inside.
  cv::Point2d blob_center(int level, cv::Point2d seed, double fraction = 0.5, bool* cut = nullptr);
  const SaliencyConfig& config() const { return config_; }

 private:
  void bind(const Retina& retina);
  // compute()'s steps, in order: each level's own features, the contrast
  // between levels, and their weighted sum.
  void level_features(std::size_t k, const cv::Mat& level, bool color, const cv::Mat* motion_dI, bool use_color);
  void center_surround();
  void combine(bool use_motion, bool use_color);
  SaliencyConfig config_;
  filters::FilterBank edges_;
  std::array<cv::Mat, filters::kFeatureCount> bank_out_;
  std::vector<cv::Mat> gray_, blurred_, contrast_, edge_, motion_, color_, maps_, appearance_;
  std::vector<LevelGeometry> geometry_;
  bool has_motion_ = false;
  cv::Mat surround_;
  cv::Mat visited_;
  std::vector<cv::Point> stack_;
};

}  // namespace saccade::fovea
