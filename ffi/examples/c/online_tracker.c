/* The online calibration loop through the gpecnet C API: detections in,
 * calibrated forecasts out, one call per camera frame.
 *
 *   cc -std=c11 -I ffi/include ffi/examples/c/online_tracker.c \
 *      target/debug/libgpecnet_ffi.a -lpthread -ldl -lm -o online_tracker
 *   ./online_tracker weights/sdd-m-lp-qe.gpec
 *
 * A synthetic 10 Hz scene in metres, 30 s: a walker (id 7), a pedestrian who
 * stands for 12 s and then starts walking (id 3), and one who crosses for 12 s
 * and leaves (id 11). Each frame goes through gpecnet_forecaster_frame: the
 * forecaster resamples the detections onto the model's 0.4 s grid, scores
 * each track's earlier forecasts against the positions it now sees (the
 * radii per horizon and the point forecast's expert weights learn from
 * that), and forecasts every track that gained a grid point. Per forecast
 * one line: where the pedestrian is expected 4.8 s later, with the 90 %
 * radius, then the bits of (id, end_ms, point[11], r90[11], r90[0]). At the
 * end, the calibration state (what a drone keeps across flights) and its
 * CRC, restored into a second forecaster. `ffi/tests/c_examples.rs` checks
 * every line against the core's `online::Forecaster`, bit for bit. */
#include <stdalign.h>
#include <stdio.h>
#include <stdlib.h>

#include "common.h"
#include "gpecnet.h"

enum { FRAMES = 300, MAX_DETS = 3 };

static alignas(GPECNET_PREDICTOR_ALIGN) unsigned char predictor_mem[GPECNET_PREDICTOR_SIZE];
static alignas(GPECNET_FORECASTER_ALIGN) unsigned char forecaster_mem[GPECNET_FORECASTER_SIZE];
static alignas(GPECNET_FORECASTER_ALIGN) unsigned char restored_mem[GPECNET_FORECASTER_SIZE];

/* The scene at frame f (t_ms = 100 f): the detections, returns how many. */
static size_t scene(uint32_t f, GpecnetDetection dets[MAX_DETS]) {
    float t = (float)(f * 100u) / 1000.0f;
    size_t n = 0;
    dets[n++] = (GpecnetDetection){.id = 7, .x = -4.0f + 1.3f * t, .y = 2.0f + 0.1f * t};
    /* Stands (with 2 cm of detector jitter) until 12 s, then walks at 1.1 m/s. */
    float jitter = 0.02f * (float)((f * 7u) % 5u) - 0.04f;
    float walk = t < 12.0f ? 0.0f : 1.1f * (t - 12.0f);
    dets[n++] = (GpecnetDetection){.id = 3, .x = 5.0f + jitter, .y = -1.0f + walk};
    /* Crosses from 3 s to 15 s, then leaves the field of view. */
    if (f >= 30u && f < 150u) {
        dets[n++] = (GpecnetDetection){.id = 11, .x = 8.0f - 0.8f * t, .y = 4.0f};
    }
    return n;
}

static const char *motion_name(uint8_t m) {
    switch (m) {
    case GPECNET_MOTION_STANDING: return "standing";
    case GPECNET_MOTION_SLOW: return "slow";
    case GPECNET_MOTION_WALKING: return "walking";
    default: return "fast";
    }
}

int main(int argc, char **argv) {
    /* The model in metres and the loop's defaults; 1 s without a detection
     * ends a track. */
    OnlineExample ex;
    int rc = online_start(argc, argv, predictor_mem, sizeof predictor_mem, forecaster_mem,
                          sizeof forecaster_mem, &ex);
    if (rc != 0) return rc;

    static GpecnetTrackForecast out[GPECNET_ONLINE_TRACKS];
    for (uint32_t f = 0; f < FRAMES; f++) {
        GpecnetDetection dets[MAX_DETS];
        size_t n_dets = scene(f, dets);
        size_t n = 0;
        if (online_frame(ex.fc, ex.p, f * 100u, dets, n_dets, out, &n) != 0) return 1;
        for (size_t i = 0; i < n; i++) {
            const GpecnetTrackForecast *o = &out[i];
            const float *end = o->point[GPECNET_ONLINE_HORIZONS - 1];
            float r90 = o->r90[GPECNET_ONLINE_HORIZONS - 1];
            printf("t=%5u ms id=%2u %-8s in 4.8 s: (%6.2f, %6.2f) m, r90 %.2f m "
                   "[%08x %08x %08x %08x %08x %08x]\n",
                   (unsigned)o->end_ms, (unsigned)o->id, motion_name(o->motion), end[0], end[1],
                   r90, (unsigned)o->id, (unsigned)o->end_ms, (unsigned)bits(end[0]),
                   (unsigned)bits(end[1]), (unsigned)bits(r90), (unsigned)bits(o->r90[0]));
        }
    }

    /* What the loop learned, as a drone would keep it across flights. */
    uint32_t counts[GPECNET_ONLINE_MOTION_STATES];
    int32_t s = gpecnet_forecaster_feedback(ex.fc, counts, GPECNET_ONLINE_MOTION_STATES);
    if (s != GPECNET_OK) return fail("gpecnet_forecaster_feedback", s);
    printf("feedback: standing %u, slow %u, walking %u, fast %u\n", (unsigned)counts[0],
           (unsigned)counts[1], (unsigned)counts[2], (unsigned)counts[3]);
    static uint8_t state[GPECNET_ONLINE_STATE_LEN];
    size_t len = 0;
    s = gpecnet_forecaster_state(ex.fc, state, sizeof state, &len);
    if (s != GPECNET_OK) return fail("gpecnet_forecaster_state", s);
    /* The state ends with its CRC-32, little endian. */
    uint32_t crc = (uint32_t)state[len - 4] | (uint32_t)state[len - 3] << 8 |
                   (uint32_t)state[len - 2] << 16 | (uint32_t)state[len - 1] << 24;
    printf("state: %u bytes, crc %08x\n", (unsigned)len, (unsigned)crc);

    /* Next flight: a fresh forecaster starts from the saved calibration. */
    s = gpecnet_forecaster_init(restored_mem, sizeof restored_mem, ex.p, &ex.cfg, 1000);
    if (s != GPECNET_OK) return fail("gpecnet_forecaster_init", s);
    GpecnetForecaster *next = (GpecnetForecaster *)restored_mem;
    s = gpecnet_forecaster_restore(next, state, len);
    if (s != GPECNET_OK) return fail("gpecnet_forecaster_restore", s);
    /* A damaged state is refused and changes nothing. */
    state[100] ^= 0x01u;
    s = gpecnet_forecaster_restore(next, state, len);
    printf("restored; a damaged copy: %s\n", gpecnet_status_str(s));
    free(ex.blob);
    return s == GPECNET_E_ONLINE_STATE_CRC ? 0 : 1;
}
