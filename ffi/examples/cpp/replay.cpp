// Replays a shipped golden file through the gpecnet C API from C++, bit for bit.
//
//   c++ -std=c++17 -I ffi/include ffi/examples/cpp/replay.cpp
//       target/debug/libgpecnet_ffi.a -lpthread -ldl -lm -o replay_cpp
//   ./replay_cpp weights/sdd-tiny-v2.gpec weights/sdd-tiny-v2.golden
//
// The same checks as examples/c/replay.c, with a small RAII-free C++ wrapper:
// the predictor lives in an aligned std::array the caller owns.
#include <array>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iterator>
#include <vector>

#include "gpecnet.h"

namespace {

std::vector<uint8_t> read_file(const char* path) {
    std::ifstream f(path, std::ios::binary);
    return {std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>()};
}

// Thin typed wrapper over the C API: caller-owned storage, status codes.
class Forecaster {
  public:
    // `blob` must outlive the Forecaster (the library reads it in place).
    int32_t init(const std::vector<uint8_t>& blob) {
        return gpecnet_init(storage_.data(), storage_.size(), blob.data(), blob.size());
    }
    GpecnetPredictor* get() { return reinterpret_cast<GpecnetPredictor*>(storage_.data()); }

  private:
    alignas(GPECNET_PREDICTOR_ALIGN) std::array<unsigned char, GPECNET_PREDICTOR_SIZE> storage_{};
};

bool same_bits(const float* a, const float* b) { return std::memcmp(a, b, 2 * sizeof(float)) == 0; }

}  // namespace

int main(int argc, char** argv) {
    if (argc != 3) {
        std::fprintf(stderr, "usage: %s MODEL.gpec MODEL.golden\n", argv[0]);
        return 2;
    }
    const std::vector<uint8_t> blob = read_file(argv[1]);
    const std::vector<uint8_t> golden = read_file(argv[2]);
    if (blob.empty() || golden.empty()) {
        std::fprintf(stderr, "cannot read %s or %s\n", argv[1], argv[2]);
        return 2;
    }
    static Forecaster f;  // ~5 KiB: static, like on a flight controller
    int32_t s = f.init(blob);
    if (s != GPECNET_OK) {
        std::fprintf(stderr, "gpecnet_init: %s\n", gpecnet_status_str(s));
        return 1;
    }
    GpecnetModelInfo info{};
    gpecnet_model_info(f.get(), &info);
    GpecnetGoldenInfo g{};
    s = gpecnet_golden_info(golden.data(), golden.size(), &g);
    if (s != GPECNET_OK || g.model_crc != info.crc) {
        std::fprintf(stderr, "golden file: %s\n",
                     s != GPECNET_OK ? gpecnet_status_str(s) : "for other weights");
        return 1;
    }

    static GpecnetGoldenCase c;
    unsigned long values = 0, bad = 0, failed = 0;
    for (uint32_t i = 0; i < g.n_cases; ++i) {
        if ((s = gpecnet_golden_case(golden.data(), golden.size(), i, &c)) != GPECNET_OK) {
            std::fprintf(stderr, "case %u: %s\n", i, gpecnet_status_str(s));
            return 1;
        }
        std::array<std::array<float, 2>, GPECNET_GOLDEN_MAX_K> ends{};
        s = gpecnet_predict_endpoints(f.get(), &c.past_xy[0][0], c.past_len, c.seed, ends[0].data(), c.k);
        if (s != GPECNET_OK) {
            ++failed;
            continue;
        }
        for (uint32_t e = 0; e < c.k; ++e, ++values) bad += !same_bits(ends[e].data(), c.endpoints_xy[e]);
        if (c.point_len > 0) {
            std::array<std::array<float, 2>, GPECNET_MAX_FUTURE> point{};
            size_t n = 0;
            s = gpecnet_predict_point(f.get(), &c.past_xy[0][0], c.past_len, point[0].data(), point.size(), &n);
            if (s != GPECNET_OK || n != c.point_len) {
                ++failed;
                continue;
            }
            for (size_t t = 0; t < n; ++t, ++values) bad += !same_bits(point[t].data(), c.point_xy[t]);
        }
    }
    std::printf("%s (%s, %s): %u cases, %lu values, %lu differ, %lu calls failed\n", info.name,
                info.numeric == GPECNET_NUMERIC_Q15 ? "q15" : "f32", g.sine, g.n_cases, values, bad, failed);
    return (bad == 0 && failed == 0 && values > 0) ? 0 : 1;
}
