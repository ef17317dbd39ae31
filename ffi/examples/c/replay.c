/* Replays a shipped golden file through the gpecnet C API, bit for bit.
 *
 *   cc -std=c11 -I ffi/include ffi/examples/c/replay.c target/debug/libgpecnet_ffi.a \
 *      -lpthread -ldl -lm -o replay
 *   ./replay weights/sdd-tiny-v2-qe.gpec weights/sdd-tiny-v2-qe.golden
 *
 * For every case: the model's endpoint set (case.k endpoints, case.seed) and,
 * when recorded, the point forecast, compared with the golden bits. Exits 0
 * only when every value matches. */
#include <stdalign.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "common.h"
#include "gpecnet.h"

/* The predictor lives here: no malloc inside the library. */
static alignas(GPECNET_PREDICTOR_ALIGN) unsigned char storage[GPECNET_PREDICTOR_SIZE];

static int same_bits(const float *a, const float *b, size_t n_floats) {
    return memcmp(a, b, n_floats * sizeof(float)) == 0;
}

int main(int argc, char **argv) {
    if (argc != 3) {
        fprintf(stderr, "usage: %s MODEL.gpec MODEL.golden\n", argv[0]);
        return 2;
    }
    size_t blob_len = 0, golden_len = 0;
    /* The blob must outlive the predictor: it is read in place. */
    unsigned char *blob = read_file(argv[1], &blob_len);
    unsigned char *golden = read_file(argv[2], &golden_len);
    if (!blob || !golden) {
        fprintf(stderr, "cannot read %s or %s\n", argv[1], argv[2]);
        return 2;
    }

    int32_t s = gpecnet_init(storage, sizeof storage, blob, blob_len);
    if (s != GPECNET_OK) return fail("gpecnet_init", s);
    GpecnetPredictor *p = (GpecnetPredictor *)storage;
    GpecnetModelInfo info;
    gpecnet_model_info(p, &info);

    GpecnetGoldenInfo g;
    s = gpecnet_golden_info(golden, golden_len, &g);
    if (s != GPECNET_OK) {
        fprintf(stderr, "golden file: %s\n", gpecnet_status_str(s));
        return 1;
    }
    if (g.model_crc != info.crc) {
        fprintf(stderr, "golden file is for other weights\n");
        return 1;
    }

    static GpecnetGoldenCase c; /* ~1 KiB: keep it off the stack */
    unsigned long values = 0, bad = 0, failed = 0;
    for (uint32_t i = 0; i < g.n_cases; i++) {
        s = gpecnet_golden_case(golden, golden_len, i, &c);
        if (s != GPECNET_OK) {
            fprintf(stderr, "case %u: %s\n", (unsigned)i, gpecnet_status_str(s));
            return 1;
        }
        float ends[GPECNET_GOLDEN_MAX_K][2];
        s = gpecnet_predict_endpoints(p, &c.past_xy[0][0], c.past_len, c.seed, &ends[0][0], c.k);
        if (s != GPECNET_OK) {
            fprintf(stderr, "case %u endpoints: %s\n", (unsigned)i, gpecnet_status_str(s));
            failed++;
            continue;
        }
        for (uint32_t e = 0; e < c.k; e++) {
            values++;
            bad += !same_bits(ends[e], c.endpoints_xy[e], 2);
        }
        if (c.point_len > 0) {
            float point[GPECNET_MAX_FUTURE][2];
            size_t n = 0;
            s = gpecnet_predict_point(p, &c.past_xy[0][0], c.past_len, &point[0][0],
                                      GPECNET_MAX_FUTURE, &n);
            if (s != GPECNET_OK || n != c.point_len) {
                fprintf(stderr, "case %u point: %s\n", (unsigned)i, gpecnet_status_str(s));
                failed++;
                continue;
            }
            for (size_t t = 0; t < n; t++) {
                values++;
                bad += !same_bits(point[t], c.point_xy[t], 2);
            }
        }
    }
    printf("%s (%s, %s): %u cases, %lu values, %lu differ, %lu calls failed\n", info.name,
           info.numeric == GPECNET_NUMERIC_Q15 ? "q15" : "f32", g.sine, (unsigned)g.n_cases,
           values, bad, failed);
    free(golden);
    free(blob);
    return (bad == 0 && failed == 0 && values > 0) ? 0 : 1;
}
