// calibration_node, TF (~publish_tf, off by default): the rotation part of an accepted calibration
// matrix n as a static transform on /tf_static, so that a robot carrying both instruments can use
// the measured relative orientation of their sensor frames (docs/frames.md).
//
// Convention. n is the matrix of T = R n (rows are samples, calibration_node.hpp): column l of
// n is test axis l in reference-frame coordinates. Its rotation part is the orthogonal factor U
// of the polar decomposition n = U P (P symmetric positive definite; U = W V^T from the SVD
// n = W S V^T, the rotation nearest to n in the Frobenius norm); the scale-factor ratios and the
// non-orthogonality are in P and are left out. U's columns are the test axes in the reference
// frame, so U takes test-frame coordinates to reference-frame coordinates: it is the rotation of
// the TF transform with header.frame_id = the reference stream's frame_id (parent) and
// child_frame_id = the test stream's frame_id (+ ~tf_child_frame_suffix), as REP-103 frames are
// related in TF. It is the inverse of the rotation whose rotation vector the message gives as
// misalignment_deg (that one, Q = U^T, takes reference to test coordinates), and its uncertainty
// is misalignment_ci95_deg. Translation: zero (the estimate says nothing about positions).
// Not published: rejected windows, a stream without frame_id, child frame = parent frame, and
// det(n) <= 0 (axes of opposite handedness: no rotation relates them); the reason is in the
// diagnostics ("tf state").
#include "magnetometer_insitu_calibration/ros/calibration_node.hpp"

#include "calibration_node_channel.hpp"
#include "magnetometer_insitu_calibration/estimation/decomposition.hpp"

#include <geometry_msgs/TransformStamped.h>

#include <Eigen/Geometry>
#include <Eigen/LU>

#include <cmath>

namespace magnetometer_insitu_calibration {

void CalibrationNode::publish_rotation(Channel& ch, const MagnetometerCalibration& m) {
  if (!tf_broadcaster_ || !m.accepted) return;
  Eigen::Matrix3d n;
  for (int k = 0; k < 9; ++k) n(k / 3, k % 3) = m.matrix[k];
  const std::string child = m.test_frame_id + settings_.tf_child_frame_suffix;
  std::string problem;
  if (m.reference_frame_id.empty() || m.test_frame_id.empty()) {
    problem = "not published: a stream has an empty frame_id (reference '" + m.reference_frame_id + "', test '" +
              m.test_frame_id + "')";
  } else if (child == m.reference_frame_id) {
    problem = "not published: child frame '" + child + "' is the reference frame (set the drivers' ~frame_id or ~tf_child_frame_suffix)";
  } else if (!n.allFinite() || !(n.determinant() > 0.0)) {
    problem = "not published: det(n) <= 0, the axes are of opposite handedness (no rotation relates them)";
  }
  if (!problem.empty()) {
    ROS_WARN("%s: test '%s': tf %s", node_name_.c_str(), ch.settings.name.c_str(), problem.c_str());
    std::lock_guard<std::mutex> lock(ch.results_mutex);
    ch.tf_state = problem;
    return;
  }
  // Test-frame coordinates -> reference-frame coordinates (columns: test axes in the reference frame).
  const Eigen::Matrix3d rotation = polar_orthogonal_factor(n);
  const Eigen::Quaterniond q = Eigen::Quaterniond(rotation).normalized();
  geometry_msgs::TransformStamped transform;
  transform.header.stamp = m.header.stamp;
  transform.header.frame_id = m.reference_frame_id;
  transform.child_frame_id = child;
  transform.transform.rotation.w = q.w();
  transform.transform.rotation.x = q.x();
  transform.transform.rotation.y = q.y();
  transform.transform.rotation.z = q.z();
  // translation stays 0 m.
  tf_broadcaster_->sendTransform(transform);  // replaces this child's earlier transform on /tf_static

  std::lock_guard<std::mutex> lock(ch.results_mutex);
  ++ch.tf_published;
  ch.tf_state = "published " + m.reference_frame_id + " -> " + child;
  ch.tf_angle_deg = Eigen::AngleAxisd(rotation).angle() * 180.0 / M_PI;
}

}  // namespace magnetometer_insitu_calibration
