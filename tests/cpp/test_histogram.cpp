// test_histogram.cpp -- bucket arithmetic, percentiles and the JSON listing of the stats histograms.
#include "stats/histogram.hpp"
#include "stats/summary.hpp"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <limits>
#include <memory>
#include <random>
#include <vector>

using namespace irp::stats;

TEST(Histogram, SmallValuesHaveTheirOwnBucket) {
    for (uint64_t v = 0; v < kSubBuckets; ++v) {
        EXPECT_EQ(bucketOf(v), v);
        EXPECT_EQ(bucketLow(v), v);
        EXPECT_EQ(bucketWidth(v), 1u);
    }
}

TEST(Histogram, EveryValueFallsInsideItsBucket) {
    std::mt19937_64 rng(7);
    for (int i = 0; i < 100000; ++i) {
        uint64_t v = rng() >> (rng() % 64);
        if (v >= (uint64_t{1} << (kMaxExponent + 1))) continue;
        std::size_t b = bucketOf(v);
        ASSERT_LE(bucketLow(b), v) << v;
        ASSERT_LT(v, bucketLow(b) + bucketWidth(b)) << v;
        ASSERT_LE(static_cast<double>(bucketWidth(b)), static_cast<double>(bucketLow(b)) / 31.0 + 1) << v;
    }
}

TEST(Histogram, HugeValuesGoToTheLastBucket) {
    EXPECT_EQ(bucketOf(UINT64_MAX), kBuckets - 1);
    EXPECT_EQ(bucketOf(uint64_t{1} << 50), kBuckets - 1);
}

TEST(Histogram, PercentilesOfAUniformSpread) {
    auto h = std::make_unique<Histogram>();
    h->reset();
    for (uint64_t v = 1; v <= 100000; ++v) h->record(v);
    Summary s = summarize(*h);
    EXPECT_EQ(s.count, 100000u);
    EXPECT_EQ(s.min, 1);
    EXPECT_EQ(s.max, 100000);
    EXPECT_NEAR(s.mean, 50000.5, 0.01);
    EXPECT_NEAR(s.p50, 50000, 50000 * 0.032);
    EXPECT_NEAR(s.p99, 99000, 99000 * 0.032);
    EXPECT_NEAR(s.p999, 99900, 99900 * 0.032);
}

TEST(Histogram, PercentilesAreClampedToTheExtremes) {
    auto h = std::make_unique<Histogram>();
    h->reset();
    for (int i = 0; i < 10; ++i) h->record(1000);
    Summary s = summarize(*h);
    EXPECT_EQ(s.p50, 1000);
    EXPECT_EQ(s.p999, 1000);
}

TEST(Histogram, EmptyIsAllZero) {
    auto h = std::make_unique<Histogram>();
    h->reset();
    Summary s = summarize(*h);
    EXPECT_EQ(s.count, 0u);
    EXPECT_EQ(s.max, 0);
}

TEST(SignedHistogram, NegativeAndPositiveValuesKeepTheirOrder) {
    auto h = std::make_unique<SignedHistogram>();
    h->reset();
    for (int64_t v = -500; v <= 499; ++v) h->record(v * 100);  // -50000 .. 49900
    Summary s = summarize(*h);
    EXPECT_EQ(s.count, 1000u);
    EXPECT_EQ(s.min, -50000);
    EXPECT_EQ(s.max, 49900);
    EXPECT_NEAR(s.mean, -50, 0.01);
    EXPECT_NEAR(s.p50, -100, 1600);  // the 500th value is -100
    EXPECT_NEAR(s.p99, 48900, 48900 * 0.032);
    EXPECT_LT(quantile(*h, 0.01), -48000);
    EXPECT_LT(quantile(*h, 0.25), 0);
    EXPECT_GT(quantile(*h, 0.75), 0);
}

TEST(SignedHistogram, AllNegative) {
    auto h = std::make_unique<SignedHistogram>();
    h->reset();
    h->record(-10);
    h->record(-20);
    Summary s = summarize(*h);
    EXPECT_EQ(s.min, -20);
    EXPECT_EQ(s.max, -10);
    EXPECT_EQ(s.mean, -15);
    EXPECT_EQ(s.p999, -10);
}

// Every recorded value lies in exactly one listed bucket [low, low + width), and the buckets of a
// signed histogram ascend from its most negative value.
TEST(HistogramJson, BucketsHoldEveryValueInAscendingOrder) {
    auto h = std::make_unique<SignedHistogram>();
    h->reset();
    const std::vector<int64_t> values = {-70'000, -1'234, -33, -1, 0, 0, 7, 31, 32, 1'000, 123'456};
    for (int64_t v : values) h->record(v);
    const nlohmann::ordered_json j = histogramJson(*h);
    EXPECT_EQ(j["count"], values.size());
    EXPECT_EQ(j["min"], -70'000);
    EXPECT_EQ(j["max"], 123'456);
    int64_t end = std::numeric_limits<int64_t>::min();
    uint64_t listed = 0;
    for (const auto &b : j["buckets"]) {
        const int64_t low = b[0], width = b[1];
        EXPECT_GE(low, end);
        end = low + width;
        uint64_t inside = 0;
        for (int64_t v : values) inside += v >= low && v < end;
        EXPECT_EQ(b[2].get<uint64_t>(), inside) << "bucket [" << low << ", " << end << ")";
        listed += b[2].get<uint64_t>();
    }
    EXPECT_EQ(listed, values.size());

    auto u = std::make_unique<Histogram>();
    u->reset();
    EXPECT_EQ(histogramJson(*u)["buckets"].size(), 0u);
    EXPECT_EQ(histogramJson(*u)["count"], 0);
    for (uint64_t v : {5u, 5u, 40u, 40'000u}) u->record(v);
    const nlohmann::ordered_json k = histogramJson(*u);
    EXPECT_EQ(k["buckets"].size(), 3u);
    EXPECT_EQ(k["buckets"][0], nlohmann::ordered_json::array({5, 1, 2}));
    EXPECT_EQ(k["min"], 5);
    EXPECT_EQ(k["max"], 40'000);
}
