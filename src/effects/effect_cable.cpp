// The `cable` effect: linear spring (rest length 0) from a point on the tool to an anchor fixed in
// the base; linear parametrisation and identifiability in include/ftid/effects/cable.hpp.
#include <memory>
#include <string>
#include <vector>

#include "ftid/common/error.hpp"
#include "ftid/effects/cable.hpp"
#include "ftid/effects/effect.hpp"

namespace ftid::effects {

namespace {

using RegressorRef = Eigen::Ref<Eigen::Matrix<double, 6, Eigen::Dynamic>>;

constexpr const char* kAxis = "xyz";

class CableEffect final : public Effect {
 public:
  std::string name() const override { return "cable"; }
  std::string description() const override {
    return "a cable or hose pulling the tool toward a fixed anchor (linear spring, rest length 0)";
  }
  std::vector<ParamInfo> params() const override {
    std::vector<ParamInfo> p;
    p.push_back({kCableStiffnessParam, "N/m", "cable stiffness k"});
    for (int i = 0; i < 3; ++i) {
      p.push_back({kCableAttachParams[i], "N",
                   std::string("k times the attachment point on the tool, ") + kAxis[i] + "_S"});
    }
    p.push_back({"cable_kp_z", "N", "k times the anchor height in B (vertical constant pull)"});
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) {
        p.push_back({std::string("cable_m_") + kAxis[i] + kAxis[j], "N*m",
                     std::string("moment term a_") + kAxis[i] + " (k p_K)_" + kAxis[j] +
                         " (attachment x anchor pull, relaxed)"});
      }
    }
    return p;
  }
  std::vector<std::string> requires() const override { return {"gravity", "tilt"}; }
  bool foldsIntoTilt() const override { return true; }  // its horizontal pull (file comment)
  void bind(const ParamIndex& index) override {
    k_ = requireColumn(index, kCableStiffnessParam, name());
    for (int i = 0; i < 3; ++i) u_[i] = requireColumn(index, kCableAttachParams[i], name());
    vz_ = requireColumn(index, "cable_kp_z", name());
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) {
        m_[i][j] = requireColumn(index, std::string("cable_m_") + kAxis[i] + kAxis[j], name());
      }
    }
  }
  void addRegressor(const SampleContext& ctx, RegressorRef Y) const noexcept override {
    const Mat3 Rt = ctx.R_BS.transpose();
    const Vec3 p_S = Rt * ctx.p_BS_B;  // sensor position in B, expressed in S
    // k: force -R^T p_BS.
    for (int r = 0; r < 3; ++r) Y(r, k_) += -p_S(r);
    // u_i = k a_i: force -e_i, moment -(e_i x R^T p_BS).
    for (int i = 0; i < 3; ++i) {
      Y(i, u_[i]) += -1.0;
      const Vec3 mom = -Vec3::Unit(i).cross(p_S);
      for (int r = 0; r < 3; ++r) Y(3 + r, u_[i]) += mom(r);
    }
    // v_z: force R^T e_z.
    for (int r = 0; r < 3; ++r) Y(r, vz_) += Rt(r, 2);
    // P_ij: moment e_i x (R^T e_j).
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) {
        const Vec3 mom = Vec3::Unit(i).cross(Rt.col(j));
        for (int r = 0; r < 3; ++r) Y(3 + r, m_[i][j]) += mom(r);
      }
    }
  }
  std::unique_ptr<Effect> clone() const override { return std::make_unique<CableEffect>(*this); }

 private:
  int k_ = 0;
  int u_[3] = {0, 0, 0};
  int vz_ = 0;
  int m_[3][3] = {{0, 0, 0}, {0, 0, 0}, {0, 0, 0}};
};

}  // namespace

std::unique_ptr<Effect> makeCableEffect(const std::string& args) {
  if (!args.empty()) throw ConfigError("effect 'cable' takes no arguments (got '" + args + "')");
  return std::make_unique<CableEffect>();
}

}  // namespace ftid::effects
