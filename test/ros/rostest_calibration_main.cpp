// rostest with a real master: simulated reference and test streams (core simulator, known
// n_true, 1 Hz) published with a /clock much faster than real time into calibration_node and
// correction_node (launched by the .test files of this folder). One TEST per .test file, picked
// with --gtest_filter (sources: rostest_calibration_<topic>.cpp, harness: calibration_harness.hpp):
//   Calibration.Nominal        nominal.test       accepted calibration near n_true (truth_bound),
//                                                 offset near the truth, YAML file, corrected
//                                                 stream equal to the clean field (absolute level),
//                                                 bad calibration files
//   Calibration.ChangeDetected test_calibration_change.test  scale ratio steps mid-run: change WARN
//                                                 after the step, never before
//   Calibration.ResumeAfterRestart test_calibration_resume.test  calibration_node started, killed
//                                                 and restarted by the test: the persisted
//                                                 calibration is published at once
//   Calibration.SilentTopic    silent_topic.test  test stream stops for 20 min
//   Calibration.TimeJump       time_jump.test     stamps jump forward by an hour
//   Calibration.Decimation10Hz decimation.test    10 Hz inputs decimated to 1 Hz in the node
//   Calibration.TwoInstruments two_instruments.test  a ~tests list: two test instruments, one node
//   Calibration.ThreeCorneredHat three_cornered_hat.test  two tests of different noise: the hat
//   Calibration.CorrectionFileReload correction_reload.test  correction_node's calibration file
//   Calibration.BadParameters  bad_parameters.test  impossible parameters: the node exits naming them
//   Calibration.TemperatureTerms temperature.test  hut temperature on a Temperature topic: terms
//                                                 fitted within their intervals, correction with
//                                                 them closer to the field than without
//   Calibration.LateRemoteFiles late_remote.test  a remote observatory's IAGA-2002 file, appended
//                                                 2 h behind the pair, followed by
//                                                 record_file_follower: windows wait for it up to
//                                                 ~remote_max_wait, then go on without it
//   Calibration.RotationOnTfStatic calibration_tf.test  ~publish_tf: the rotation part of n on
//                                                 /tf_static; nothing from a node without it
#include <gtest/gtest.h>
#include <ros/ros.h>

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "calibration_rostest");
  ros::NodeHandle keep_alive;  // roscpp (and its logging) stays up for every TEST
  return RUN_ALL_TESTS();
}
