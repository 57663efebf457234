// Robot kinematics: urdfdom model -> KDL::Chain (our own small conversion, no kdl_parser), then a
// forward recursion over the chain's segments for pose, velocity and acceleration of the sensor
// frame. KDL has no acceleration forward kinematics, so the recursion is written here:
// for every segment, with o the joint's point on its axis and z its unit axis (both in B),
//   w'     = w + z qd                      alpha' = alpha + z qdd + w x (z qd)
//   a_o    = a + alpha x (o - p) + w x (w x (o - p))          (o is fixed in the parent body)
//   a'     = a_o + alpha' x (p' - o) + w' x (w' x (p' - o))   (p' is fixed in the child body)
// where p, p' are the segment's start/end frame origins. Everything is fixed-size (KDL::Frame,
// KDL::Vector live on the stack), so computeSensorMotion does not allocate.
#include "ftid/model/kinematics.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>
#include <utility>
#include <vector>

#include <kdl/chain.hpp>
#include <kdl/frames.hpp>
#include <kdl/joint.hpp>
#include <kdl/segment.hpp>
#include <urdf_model/model.h>
#include <urdf_parser/urdf_parser.h>

#include "ftid/fileio/input_file.hpp"
#include "ftid/common/error.hpp"

namespace ftid::model {

struct RobotKinematics::Impl {
  KDL::Chain chain;  ///< base_link -> tip_link, one segment per URDF joint (fixed ones included)
  std::vector<int> movable_index;  ///< per segment: index of its joint in q (0..5) or -1 if fixed
  JointLimits limits;
  std::array<std::string, kNumJoints> joint_names;
  std::string source;
  KDL::Frame X_FS = KDL::Frame::Identity();
};

namespace {

KDL::Vector toKdl(const urdf::Vector3& v) { return KDL::Vector(v.x, v.y, v.z); }

KDL::Frame toKdl(const urdf::Pose& p) {
  double x = 0.0, y = 0.0, z = 0.0, w = 1.0;
  p.rotation.getQuaternion(x, y, z, w);
  return KDL::Frame(KDL::Rotation::Quaternion(x, y, z, w), toKdl(p.position));
}

Mat3 toEigen(const KDL::Rotation& r) {
  Mat3 m;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) m(i, j) = r(i, j);
  return m;
}

Vec3 toEigen(const KDL::Vector& v) { return Vec3(v.x(), v.y(), v.z()); }

Eigen::Isometry3d toIsometry(const KDL::Frame& f) {
  Eigen::Isometry3d x = Eigen::Isometry3d::Identity();
  x.linear() = toEigen(f.M);
  x.translation() = toEigen(f.p);
  return x;
}

[[noreturn]] void fail(const std::string& source, const std::string& what) {
  throw ConfigError(source + ": " + what);
}

}  // namespace

std::size_t xmlNestingDepth(std::string_view xml) {
  std::size_t depth = 0, deepest = 0;
  std::size_t i = 0;
  const std::size_t n = xml.size();
  auto skipPast = [&](std::string_view end) {
    const std::size_t k = xml.find(end, i);
    i = k == std::string_view::npos ? n : k + end.size();
  };
  while (i < n) {
    const std::size_t lt = xml.find('<', i);
    if (lt == std::string_view::npos) break;
    i = lt + 1;
    const std::string_view rest = xml.substr(i);
    if (rest.substr(0, 3) == "!--") {
      skipPast("-->");
    } else if (rest.substr(0, 8) == "![CDATA[") {
      skipPast("]]>");
    } else if (!rest.empty() && (rest.front() == '?' || rest.front() == '!')) {
      skipPast(">");  // declaration, processing instruction, DOCTYPE
    } else if (!rest.empty() && rest.front() == '/') {
      skipPast(">");
      if (depth > 0) --depth;
    } else {
      // Start tag: find its end outside quoted attribute values.
      char quote = 0;
      bool self_closing = false;
      while (i < n) {
        const char ch = xml[i++];
        if (quote != 0) {
          if (ch == quote) quote = 0;
        } else if (ch == '"' || ch == '\'') {
          quote = ch;
        } else if (ch == '>') {
          self_closing = i >= 2 && xml[i - 2] == '/';
          break;
        }
      }
      deepest = std::max(deepest, depth + 1);
      if (!self_closing) ++depth;
    }
  }
  return deepest;
}

RobotKinematics::RobotKinematics(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
RobotKinematics::RobotKinematics(const RobotKinematics& other)
    : impl_(std::make_unique<Impl>(*other.impl_)) {}
RobotKinematics& RobotKinematics::operator=(const RobotKinematics& other) {
  if (this != &other) impl_ = std::make_unique<Impl>(*other.impl_);
  return *this;
}
RobotKinematics::RobotKinematics(RobotKinematics&&) noexcept = default;
RobotKinematics& RobotKinematics::operator=(RobotKinematics&&) noexcept = default;
RobotKinematics::~RobotKinematics() = default;

RobotKinematics RobotKinematics::fromUrdfFile(const std::string& path, const std::string& base_link,
                                              const std::string& tip_link) {
  std::string xml;
  try {
    xml = readInputFile(path, "URDF file", kMaxTextConfigBytes);
  } catch (const FileError& e) {
    throw ConfigError(e.what());
  }
  return fromUrdfString(xml, base_link, tip_link, path);
}

RobotKinematics RobotKinematics::fromUrdfString(const std::string& xml, const std::string& base_link,
                                                const std::string& tip_link,
                                                const std::string& source_name) {
  if (xml.find_first_not_of(" \t\r\n") == std::string::npos) fail(source_name, "URDF is empty");
  // The XML parser recurses once per nesting level: refuse deep nesting before it runs.
  const std::size_t depth = xmlNestingDepth(xml);
  if (depth > kMaxUrdfDepth) {
    fail(source_name, "XML elements nested " + std::to_string(depth) + " deep; a URDF needs at most " +
                          std::to_string(kMaxUrdfDepth) + " levels (refused before parsing)");
  }
  urdf::ModelInterfaceSharedPtr model;
  try {
    model = urdf::parseURDF(xml);
  } catch (const std::exception& e) {
    fail(source_name, std::string("URDF parse error: ") + e.what());
  }
  if (!model) fail(source_name, "not a valid URDF (urdfdom could not parse it; see its console message)");

  urdf::LinkConstSharedPtr tip = model->getLink(tip_link);
  if (!tip) fail(source_name, "tip link '" + tip_link + "' not found");
  if (!model->getLink(base_link)) fail(source_name, "base link '" + base_link + "' not found");

  // Walk from the tip up to the base, collecting the joints in between.
  std::vector<urdf::JointConstSharedPtr> joints;
  urdf::LinkConstSharedPtr link = tip;
  while (link->name != base_link) {
    if (!link->parent_joint) {
      fail(source_name, "link '" + tip_link + "' is not below link '" + base_link + "'");
    }
    joints.push_back(link->parent_joint);
    link = link->getParent();
    if (!link) fail(source_name, "joint '" + joints.back()->name + "' has no parent link");
  }

  auto impl = std::make_unique<Impl>();
  impl->source = source_name;
  int movable = 0;
  for (auto it = joints.rbegin(); it != joints.rend(); ++it) {
    const urdf::Joint& j = **it;
    const KDL::Frame X_parent_joint = toKdl(j.parent_to_joint_origin_transform);
    KDL::Joint kdl_joint(j.name, KDL::Joint::Fixed);
    switch (j.type) {
      case urdf::Joint::FIXED:
        break;
      case urdf::Joint::REVOLUTE:
      case urdf::Joint::CONTINUOUS: {
        KDL::Vector axis = toKdl(j.axis);
        const double n = axis.Norm();
        if (!(n > 1e-12) || !std::isfinite(n)) fail(source_name, "joint '" + j.name + "' has a zero axis");
        axis = axis / n;
        // KDL joint: rotation about an axis through `origin`, both in the segment's start frame.
        kdl_joint = KDL::Joint(j.name, X_parent_joint.p, X_parent_joint.M * axis, KDL::Joint::RotAxis);
        if (movable >= kNumJoints) {
          fail(source_name, "chain '" + base_link + "' -> '" + tip_link + "' has more than 6 movable joints");
        }
        impl->joint_names[static_cast<std::size_t>(movable)] = j.name;
        if (j.type == urdf::Joint::REVOLUTE && j.limits) {
          impl->limits.lower[movable] = j.limits->lower;
          impl->limits.upper[movable] = j.limits->upper;
          if (j.limits->velocity > 0.0) impl->limits.velocity[movable] = j.limits->velocity;
        } else if (j.limits && j.limits->velocity > 0.0) {
          impl->limits.velocity[movable] = j.limits->velocity;
        }
        break;
      }
      default:
        fail(source_name, "joint '" + j.name + "' is not revolute or fixed (only 6 revolute joints are supported)");
    }
    impl->chain.addSegment(KDL::Segment(j.child_link_name, kdl_joint, X_parent_joint));
    impl->movable_index.push_back(kdl_joint.getType() == KDL::Joint::Fixed ? -1 : movable);
    if (kdl_joint.getType() != KDL::Joint::Fixed) ++movable;
  }
  if (movable != kNumJoints) {
    fail(source_name, "chain '" + base_link + "' -> '" + tip_link + "' has " + std::to_string(movable) +
                          " revolute joints, expected 6");
  }
  return RobotKinematics(std::move(impl));
}

void RobotKinematics::setSensorMount(const Mat3& R_FS, const Vec3& p_FS_F) {
  KDL::Rotation r;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) r(i, j) = R_FS(i, j);
  impl_->X_FS = KDL::Frame(r, KDL::Vector(p_FS_F.x(), p_FS_F.y(), p_FS_F.z()));
}

Eigen::Isometry3d RobotKinematics::sensorMount() const noexcept { return toIsometry(impl_->X_FS); }

Eigen::Isometry3d RobotKinematics::computeFlangePose(const JointVector& q) const noexcept {
  KDL::Frame T = KDL::Frame::Identity();
  const auto n = impl_->chain.getNrOfSegments();
  for (unsigned int s = 0; s < n; ++s) {
    const int k = impl_->movable_index[s];
    T = T * impl_->chain.getSegment(s).pose(k >= 0 ? q[k] : 0.0);
  }
  return toIsometry(T);
}

Eigen::Isometry3d RobotKinematics::computeSensorPose(const JointVector& q) const noexcept {
  const Eigen::Isometry3d X_BF = computeFlangePose(q);
  return X_BF * toIsometry(impl_->X_FS);
}

SensorMotion RobotKinematics::computeSensorMotion(const JointVector& q, const JointVector& qd,
                                                  const JointVector& qdd) const noexcept {
  // State of the current frame, all vectors in B.
  KDL::Frame T = KDL::Frame::Identity();
  KDL::Vector w = KDL::Vector::Zero(), alpha = KDL::Vector::Zero(), a = KDL::Vector::Zero();
  const auto n = impl_->chain.getNrOfSegments();
  for (unsigned int s = 0; s < n; ++s) {
    const KDL::Segment& seg = impl_->chain.getSegment(s);
    const int k = impl_->movable_index[s];
    const KDL::Frame T_next = T * seg.pose(k >= 0 ? q[k] : 0.0);
    if (k >= 0) {
      const KDL::Joint& j = seg.getJoint();
      const KDL::Vector z = T.M * j.JointAxis();   // unit axis in B
      const KDL::Vector o = T * j.JointOrigin();   // a point on the axis, in B
      const KDL::Vector r_po = o - T.p;
      const KDL::Vector a_o = a + alpha * r_po + w * (w * r_po);
      const KDL::Vector w_next = w + z * qd[k];
      alpha = alpha + z * qdd[k] + w * (z * qd[k]);
      w = w_next;
      const KDL::Vector r_on = T_next.p - o;
      a = a_o + alpha * r_on + w * (w * r_on);
    } else {
      const KDL::Vector r = T_next.p - T.p;
      a = a + alpha * r + w * (w * r);
    }
    T = T_next;
  }
  // Fixed sensor mount.
  const KDL::Frame T_S = T * impl_->X_FS;
  const KDL::Vector r = T_S.p - T.p;
  a = a + alpha * r + w * (w * r);

  SensorMotion m;
  m.R_BS = toEigen(T_S.M);
  m.p_BS_B = toEigen(T_S.p);
  const KDL::Rotation R_SB = T_S.M.Inverse();
  m.w_S = toEigen(R_SB * w);
  m.alpha_S = toEigen(R_SB * alpha);
  m.a_S = toEigen(R_SB * a);
  return m;
}

const JointLimits& RobotKinematics::limits() const noexcept { return impl_->limits; }
const std::array<std::string, kNumJoints>& RobotKinematics::jointNames() const noexcept {
  return impl_->joint_names;
}
const std::string& RobotKinematics::sourceName() const noexcept { return impl_->source; }

}  // namespace ftid::model
