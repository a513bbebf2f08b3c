// One board identity per placement (protocols/placement_views.h): a target placed several times
// becomes one board per placement; a target the protocol never moves (a tag sheet fixed in the
// scene) stays one board while the others are placed around it.
#include "protocols/placement_views.h"

#include <gtest/gtest.h>

namespace owlcal::protocols {
namespace {

calib::View ViewOf(int frame, const std::string& target) {
  calib::View v;
  v.frame_index = frame;
  v.target_id = target;
  return v;
}

TEST(PlacementViews, FixedTagSheetStaysOneBoardWhileTheChessboardIsPlacedAgain) {
  // frames 0-1 after placement 0 (chessboard), frame 2 after placement 1 (fixation disc),
  // frames 3-4 after placement 2 (chessboard again).
  std::vector<FrameRecord> frames(5);
  const int placement_of_frame[5] = {0, 0, 1, 2, 2};
  for (int i = 0; i < 5; ++i) {
    frames[i].frame_index = i;
    frames[i].placement_index = placement_of_frame[i];
  }
  std::vector<PlacementRecord> placements(3);
  const char* target_of_placement[3] = {"chessboard", "fixation", "chessboard"};
  for (int i = 0; i < 3; ++i) {
    placements[i].placement_index = i;
    placements[i].target = target_of_placement[i];
  }
  std::vector<calib::View> views;
  for (int f = 0; f < 5; ++f) {
    views.push_back(ViewOf(f, "chessboard"));
    views.push_back(ViewOf(f, "tags_right_up"));
  }
  views.push_back(ViewOf(9, "chessboard"));  // a frame frames.csv does not list keeps its id

  const std::vector<calib::View> by_target = SplitViewsByPlacement(views, frames, &placements);
  const char* expect_chess[5] = {"chessboard@placement0",
                                 "chessboard@placement0",
                                 "chessboard@placement0",
                                 "chessboard@placement2",
                                 "chessboard@placement2"};
  for (int f = 0; f < 5; ++f) {
    EXPECT_EQ(by_target[2 * f].target_id, expect_chess[f]) << "frame " << f;
    EXPECT_EQ(by_target[2 * f + 1].target_id, "tags_right_up") << "frame " << f;
  }
  EXPECT_EQ(by_target.back().target_id, "chessboard");

  // Without the placements, every frame placement splits every target (the older rule).
  const std::vector<calib::View> by_frame = SplitViewsByPlacement(views, frames);
  EXPECT_EQ(by_frame[1].target_id, "tags_right_up@placement0");
  EXPECT_EQ(by_frame[5].target_id, "tags_right_up@placement1");
  EXPECT_EQ(by_frame[4].target_id, "chessboard@placement1");
}

}  // namespace
}  // namespace owlcal::protocols
