/* From a 30 Hz metric tracker to forecasts, through the gpecnet C API.
 *
 *   cc -std=c11 -I ffi/include ffi/examples/c/metric_tracker.c \
 *      target/debug/libgpecnet_ffi.a -lpthread -ldl -lm -o metric_tracker
 *   ./metric_tracker weights/sdd-m-tiny-qe.gpec [weights/test-signing-key.pub]
 *   ./metric_tracker weights/sdd-m-lp-qe.gpec weights/test-signing-key.pub
 *
 * With a model that has endpoint probabilities (sdd-m-lp-qe) every forecast
 * is followed by a `planner` line: r50 / r90 around the point forecast and
 * the most probable of its K endpoints (gpecnet_predict_forecast).
 *
 * With a public key file, the blob must be signed by that key
 * (gpecnet_init_signed: Ed25519, model version at least 1), as a drone that
 * takes weights over the air would load it.
 *
 * Detections in metres with millisecond timestamps (jitter, one in ten
 * missed) go into the timed track table, which resamples them onto the
 * model's 0.4 s period; every track whose history gained a point is
 * forecast by the metric model, declared in metres so that a model in
 * another unit is refused at gpecnet_init_units. The scene and the printed
 * lines are those of `cargo run -p gpecnet-core --example metric_tracker`,
 * bit for bit. */
#include <math.h>
#include <stdalign.h>
#include <stdio.h>
#include <stdlib.h>

#include "common.h"
#include "gpecnet.h"

enum { PEDESTRIANS = 6, FRAMES = 150 };

static alignas(GPECNET_PREDICTOR_ALIGN) unsigned char predictor_mem[GPECNET_PREDICTOR_SIZE];
static alignas(GPECNET_TRACKS_ALIGN) unsigned char table_mem[GPECNET_TRACKS_SIZE];

/* The synthetic camera: frame f's timestamp (30 Hz, 0-8 ms of jitter) and
 * pedestrian id's position in metres; returns 0 when the detector missed it. */
static int camera(uint32_t f, uint32_t id, uint32_t *t_ms, float pos[2]) {
    *t_ms = f * 1000u / 30u + (f * 7919u) % 9u;
    if ((f * 31u + id * 17u) % 10u == 0u) return 0;
    float t = (float)*t_ms / 1000.0f;
    float k = (float)id;
    pos[0] = 2.0f * k + (1.1f + 0.05f * k) * t;
    pos[1] = -3.0f + k + (0.3f - 0.1f * k) * t + 0.05f * t * t;
    return 1;
}

/* A public key file: 64 hex digits. */
static int read_key(const char *path, GpecnetTrustedKey *key) {
    FILE *f = fopen(path, "r");
    if (!f) return 0;
    int ok = 1;
    for (int i = 0; i < 32 && ok; i++) {
        unsigned v;
        ok = fscanf(f, "%2x", &v) == 1;
        key->public_key[i] = (uint8_t)v;
    }
    fclose(f);
    return ok;
}

int main(int argc, char **argv) {
    if (argc != 2 && argc != 3) {
        fprintf(stderr, "usage: %s MODEL.gpec [PUBLIC.key]\n", argv[0]);
        return 2;
    }
    size_t blob_len = 0;
    unsigned char *blob = read_model(argv[1], &blob_len); /* read in place: keep it */
    if (!blob) return 2;
    /* Metres in, metres out; with a key, only a blob signed by it (version >= 1). */
    int32_t s;
    if (argc == 3) {
        GpecnetTrustedKey key;
        if (!read_key(argv[2], &key)) {
            fprintf(stderr, "%s: not a public key file\n", argv[2]);
            return 2;
        }
        uint32_t version = 0;
        s = gpecnet_init_signed(predictor_mem, sizeof predictor_mem, blob, blob_len, &key, 1, 1,
                                GPECNET_UNIT_METRES, 0.0f, &version);
        if (s == GPECNET_OK) printf("signature ok: model version %u\n", (unsigned)version);
    } else {
        s = gpecnet_init_units(predictor_mem, sizeof predictor_mem, blob, blob_len,
                               GPECNET_UNIT_METRES, 0.0f);
    }
    if (s != GPECNET_OK) return fail("gpecnet_init", s);
    GpecnetPredictor *p = (GpecnetPredictor *)predictor_mem;
    GpecnetModelInfo info;
    gpecnet_model_info(p, &info);
    uint32_t period_ms = (uint32_t)lroundf(info.period_s * 1000.0f);
    /* 1 s without a detection ends a track. */
    s = gpecnet_tracks_init(table_mem, sizeof table_mem, period_ms, 1000);
    if (s != GPECNET_OK) return fail("gpecnet_tracks_init", s);
    GpecnetTracks *table = (GpecnetTracks *)table_mem;
    printf("%s: unit %s, period %u ms\n", info.name,
           info.unit == GPECNET_POSITION_METRE ? "m" : "?", (unsigned)period_ms);

    static GpecnetHistory fresh[GPECNET_TRACKS_CAPACITY];
    for (uint32_t f = 0; f < FRAMES; f++) {
        GpecnetDetection dets[PEDESTRIANS];
        size_t n = 0;
        uint32_t t_ms = 0;
        for (uint32_t id = 0; id < PEDESTRIANS; id++) {
            float pos[2];
            if (camera(f, id, &t_ms, pos)) {
                dets[n++] = (GpecnetDetection){.id = id, .x = pos[0], .y = pos[1]};
            }
        }
        s = gpecnet_tracks_update(table, t_ms, dets, n, NULL);
        if (s != GPECNET_OK) return fail("gpecnet_tracks_update", s);
        size_t n_fresh = 0;
        s = gpecnet_tracks_fresh(table, fresh, GPECNET_TRACKS_CAPACITY, &n_fresh);
        if (s != GPECNET_OK) return fail("gpecnet_tracks_fresh", s);
        for (size_t i = 0; i < n_fresh; i++) {
            float forecast[GPECNET_MAX_FUTURE][2];
            size_t len = 0;
            s = gpecnet_predict_point(p, &fresh[i].past_xy[0][0], GPECNET_HISTORY,
                                      &forecast[0][0], GPECNET_MAX_FUTURE, &len);
            if (s != GPECNET_OK || len == 0) return fail("gpecnet_predict_point", s);
            const float *end = forecast[len - 1];
            printf("t=%5u ms id=%u endpoint at %5u ms: (%.3f, %.3f) m [%08x %08x]\n",
                   (unsigned)fresh[i].end_ms, (unsigned)fresh[i].id,
                   (unsigned)(fresh[i].end_ms + period_ms * (uint32_t)len), end[0], end[1],
                   (unsigned)bits(end[0]), (unsigned)bits(end[1]));
            if (!info.has_probabilities) continue;
            /* A model with endpoint probabilities: its K endpoints, which one is the
             * most probable, and how far from the point forecast the person may be. */
            float ends[GPECNET_MAX_SAMPLES][2];
            float probs[GPECNET_MAX_SAMPLES];
            GpecnetPlanner plan;
            size_t k = info.max_endpoints;
            s = gpecnet_predict_forecast(p, &fresh[i].past_xy[0][0], GPECNET_HISTORY, 0,
                                         &ends[0][0], probs, k, &plan);
            if (s != GPECNET_OK) return fail("gpecnet_predict_forecast", s);
            size_t top = 0;
            for (size_t j = 1; j < k; j++) {
                if (probs[j] > probs[top]) top = j;
            }
            printf("  planner t=%5u ms id=%u: r50 %.3f m, r90 %.3f m, most probable e%u "
                   "(%.3f, %.3f) m p %.3f [%08x %08x]\n",
                   (unsigned)fresh[i].end_ms, (unsigned)fresh[i].id, plan.r50, plan.r90,
                   (unsigned)top, ends[top][0], ends[top][1], probs[top],
                   (unsigned)bits(plan.r90), (unsigned)bits(probs[top]));
        }
    }
    free(blob);
    return 0;
}
