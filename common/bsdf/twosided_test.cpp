// <bsdf type="twosided">: from the back, the nested BSDF seen turned over; from the front,
// the nested BSDF unchanged, bit for bit.
#include "common/bsdf/bsdf.h"
#include "common/core/frame.h"
#include "common/core/rng.h"
#include "common/core/warp.h"

#include <gtest/gtest.h>

namespace alphorn {
namespace {

std::shared_ptr<BSDF> twoSided(const std::shared_ptr<Object>& nested) {
    auto bsdf = std::static_pointer_cast<BSDF>(
        ObjectFactory::create(ObjectKind::BSDF, "twosided", PropertyList()));
    bsdf->addChild(nested, "");
    bsdf->activate();
    return bsdf;
}

std::shared_ptr<BSDF> diffuse() {
    PropertyList props;
    props.setColor("albedo", Color3f(0.2f, 0.4f, 0.6f));
    auto bsdf =
        std::static_pointer_cast<BSDF>(ObjectFactory::create(ObjectKind::BSDF, "diffuse", props));
    bsdf->activate();
    return bsdf;
}

TEST(TwoSided, TheBackShadesAsTheFrontAndTheFrontIsUnchanged) {
    auto plain = diffuse();
    auto both = twoSided(plain);
    Rng rng(3, 0, 0, StreamPurpose::Test);
    for (int i = 0; i < 200; ++i) {
        const Vector3f wi =
            warp::squareToCosineHemisphere(Point2f(rng.nextFloat(), rng.nextFloat()));
        const Vector3f wo =
            warp::squareToCosineHemisphere(Point2f(rng.nextFloat(), rng.nextFloat()));
        BSDFQueryRecord front(wi, wo, Measure::SolidAngle), back(-wi, -wo, Measure::SolidAngle);
        // The plain diffuse BSDF is black from behind; the two-sided one is not.
        EXPECT_TRUE(plain->eval(back).isBlack());
        EXPECT_TRUE((both->eval(back) == plain->eval(front)).all());
        EXPECT_TRUE((both->eval(front) == plain->eval(front)).all());
        EXPECT_EQ(both->pdf(back), plain->pdf(front));
        // Light from the other side does not pass.
        BSDFQueryRecord through(-wi, wo, Measure::SolidAngle);
        EXPECT_TRUE(both->eval(through).isBlack());
        // Sampling from the back leaves on the back, with the front's weight.
        const Point2f u(rng.nextFloat(), rng.nextFloat());
        BSDFQueryRecord sampledBack(-wi), sampledFront(wi);
        const Color3f wb = both->sample(sampledBack, u), wf = plain->sample(sampledFront, u);
        EXPECT_TRUE((wb == wf).all());
        EXPECT_TRUE(sampledBack.wo == -sampledFront.wo);
        EXPECT_TRUE(sampledBack.wi == -wi);
    }
    EXPECT_TRUE(both->isDiffuse());
}

TEST(TwoSided, NeedsOneNestedBsdf) {
    auto bsdf = ObjectFactory::create(ObjectKind::BSDF, "twosided", PropertyList());
    EXPECT_THROW(bsdf->activate(), Error);
    bsdf->addChild(diffuse(), "");
    EXPECT_THROW(bsdf->addChild(diffuse(), ""), Error);
}

}  // namespace
}  // namespace alphorn
