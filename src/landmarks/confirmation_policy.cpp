#include "landmarks/confirmation_policy.h"

#include "landmarks/baseline_policies.h"
#include "landmarks/consistency_policy.h"

namespace twocam::landmarks {

std::unique_ptr<ConfirmationPolicy> makeConfirmationPolicy(const StereoRig& rig,
                                                           const LandmarkOptions& options) {
  switch (options.policy) {
    case Policy::kConsistency:
      return std::make_unique<ConsistencyPolicy>(rig, options);
    case Policy::kWtaLrc:
      return std::make_unique<WtaLrcPolicy>();
    case Policy::kSeenCount:
      return std::make_unique<SeenCountPolicy>(options.seen_count);
    case Policy::kCulling:
      return std::make_unique<CullingPolicy>(options.culling);
    case Policy::kInlierRatio:
      return std::make_unique<InlierRatioPolicy>(rig, options);
  }
  TWOCAM_CHECK(false) << "unknown policy " << static_cast<int>(options.policy);
  return nullptr;
}

}  // namespace twocam::landmarks
