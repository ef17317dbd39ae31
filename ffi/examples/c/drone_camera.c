/* From a drone's camera to calibrated forecasts through the gpecnet C API:
 * bounding boxes in the image of a gimballed camera, and the flight stack's
 * attitude quaternion, NED position and gimbal angles at each frame, become
 * ground detections in NED metres (gpecnet_boxes_to_detections), which the
 * online forecaster turns into forecasts; each forecast's endpoint is drawn
 * back into the current image (gpecnet_ground_to_image), as an overlay would.
 *
 *   cc -std=c11 -I ffi/include ffi/examples/c/drone_camera.c \
 *      target/debug/libgpecnet_ffi.a -lpthread -ldl -lm -o drone_camera
 *   ./drone_camera weights/sdd-m-lp-qe.gpec
 *
 * The scene (core/examples/drone_camera.rs's idea): five pedestrians walk
 * north-east on gentle curves; the drone follows them at 30-34 m, wobbling in
 * roll and pitch, its gimbal 70 deg down, and yaws 90 deg in 2 s halfway
 * through. The boxes are the projections of their feet plus up to +-1 px of
 * detector noise, at 30 Hz, and every 5 s two glitches of the detector (a
 * box with NaN edges, a box far above the image), each refused with its
 * status. Per forecast one line: the endpoint 4.8 s
 * ahead in NED, its 90 % radius and where it is drawn in the image, then the
 * bits of (id, end_ms, north, east, r90 | u, v). `ffi/tests/c_examples.rs`
 * checks every line against the core's camera module and online::Forecaster,
 * bit for bit. The scene's own sine is a Taylor polynomial (below), so that
 * the Rust test computes the same inputs: C's sinf is not the core's. */
#include <math.h>
#include <stdalign.h>
#include <stdio.h>
#include <stdlib.h>

#include "common.h"
#include "gpecnet.h"

enum { FRAMES = 600, PEDESTRIANS = 5, MAX_BOXES = 8, GLITCH = 98, KITE = 99 };

static alignas(GPECNET_PREDICTOR_ALIGN) unsigned char predictor_mem[GPECNET_PREDICTOR_SIZE];
static alignas(GPECNET_FORECASTER_ALIGN) unsigned char forecaster_mem[GPECNET_FORECASTER_SIZE];

static const float PI_F = 3.14159274f;     /* pi rounded to float */
static const float TWO_PI_F = 6.28318548f; /* 2 pi rounded to float */
static const float HALF_PI_F = 1.57079637f;

/* sin and cos of |x| <= pi by their Taylor series to x^11 and x^10 (Horner,
 * float, left to right): the scene's trigonometry, exactly repeatable. */
static float psin(float x) {
    float x2 = x * x;
    return x * (1.0f - x2 / 6.0f *
                           (1.0f - x2 / 20.0f *
                                       (1.0f - x2 / 42.0f *
                                                   (1.0f - x2 / 72.0f * (1.0f - x2 / 110.0f)))));
}

static float pcos(float x) {
    float x2 = x * x;
    return 1.0f - x2 / 2.0f *
                      (1.0f - x2 / 12.0f *
                                  (1.0f - x2 / 30.0f * (1.0f - x2 / 56.0f * (1.0f - x2 / 90.0f))));
}

/* A wave of period 2 pi for any x >= 0: -sin(x), with x reduced to [-pi, pi). */
static float wave(float x) {
    float r = x - TWO_PI_F * floorf(x / TWO_PI_F);
    return psin(r - PI_F);
}

/* Pedestrian `id`'s feet at `t` seconds, {north, east} metres. */
static void pedestrian(uint32_t id, float t, float ne[2]) {
    float k = (float)id;
    float speed = 1.0f + 0.1f * k;
    float turn = 0.02f * (k - 2.0f); /* rad/s */
    float heading = 0.6f + 0.15f * k + turn * t;
    ne[0] = -4.0f + 2.0f * k + speed * t * pcos(heading);
    ne[1] = 3.0f - 1.5f * k + speed * t * psin(heading);
}

/* PX4's vehicle_attitude.q (w, x, y, z) of Z-Y-X Euler angles (each |angle| <= pi). */
static void quaternion(float roll, float pitch, float yaw, float q[4]) {
    float sr = psin(roll / 2.0f), cr = pcos(roll / 2.0f);
    float sp = psin(pitch / 2.0f), cp = pcos(pitch / 2.0f);
    float sy = psin(yaw / 2.0f), cy = pcos(yaw / 2.0f);
    q[0] = cr * cp * cy + sr * sp * sy;
    q[1] = sr * cp * cy - cr * sp * sy;
    q[2] = cr * sp * cy + sr * cp * sy;
    q[3] = cr * cp * sy - sr * sp * cy;
}

/* The flight stack at `t` seconds: following the group north-east, climbing
 * from 30 to 34 m, wobbling, yawing from 0 to 90 deg between 9 and 11 s; the
 * gimbal holds 70 deg down and compensates the vehicle's pitch. */
static GpecnetCameraState flight(float t) {
    float a = (t - 9.0f) / 2.0f;
    a = a < 0.0f ? 0.0f : (a > 1.0f ? 1.0f : a);
    float yaw = HALF_PI_F * a;
    float roll = 0.03f * wave(1.7f * t);
    float pitch = -0.05f + 0.02f * wave(2.3f * t);
    GpecnetCameraState s = {
        .position = {1.0f * t - 6.0f, 0.8f * t, -30.0f - 0.2f * t},
        .gimbal = {.roll = 0.0f, .pitch = -1.22f - pitch, .yaw = 0.0f},
        .ground_down = 0.0f,
    };
    quaternion(roll, pitch, yaw, s.attitude);
    return s;
}

/* Up to +-1 px of detector noise, deterministic. */
static float noise(uint32_t seed) {
    uint32_t h = seed * 0x9E3779B9u;
    h = ((h << 13) | (h >> 19)) ^ 0x5bd1e995u;
    return (float)(h >> 8) / 8388608.0f - 1.0f;
}

int main(int argc, char **argv) {
    /* The model in metres and the online forecaster with its defaults. */
    OnlineExample ex;
    int rc = online_start(argc, argv, predictor_mem, sizeof predictor_mem, forecaster_mem,
                          sizeof forecaster_mem, &ex);
    if (rc != 0) return rc;

    /* The camera, fixed for the flight: 1920 x 1080, a calibrated lens, the
     * gimbal's base along the body's axes, ground points up to 150 m away. */
    const GpecnetCamera camera = {
        .fx = 1100.0f, .fy = 1100.0f, .cx = 960.0f, .cy = 540.0f,
        .k1 = -0.12f, .k2 = 0.03f, .p1 = 0.0f, .p2 = 0.0f,
        .mount = {0.0f, 0.0f, 0.0f}, .max_range = 150.0f,
    };
    printf("drone_camera: %d pedestrians, boxes at 30 Hz from 30-34 m, yaw 90 deg at 9-11 s\n",
           PEDESTRIANS);

    static GpecnetTrackForecast out[GPECNET_ONLINE_TRACKS];
    uint32_t forecasts = 0, refused = 0;
    float sum_err = 0.0f;
    for (uint32_t f = 0; f < FRAMES; f++) {
        uint32_t t_ms = f * 1000u / 30u;
        float t = (float)t_ms / 1000.0f;
        const GpecnetCameraState state = flight(t);
        GpecnetPose pose;
        int32_t s = gpecnet_camera_pose(&camera, &state, &pose);
        if (s != GPECNET_OK) return fail("gpecnet_camera_pose", s);

        /* The detector: each pedestrian's box, feet at the bottom centre. */
        GpecnetBox boxes[MAX_BOXES];
        size_t n_boxes = 0;
        for (uint32_t id = 0; id < PEDESTRIANS; id++) {
            float ne[2], uv[2];
            pedestrian(id, t, ne);
            if (gpecnet_ground_to_image(&pose, ne[0], ne[1], uv) != GPECNET_OK) continue;
            float u = uv[0] + noise(f * 8u + id), v = uv[1] + noise(f * 8u + id + 4u);
            if (!(u >= 0.0f && u < 1920.0f && v >= 0.0f && v < 1080.0f)) continue;
            boxes[n_boxes++] = (GpecnetBox){
                .id = id, .x_min = u - 15.0f, .y_min = v - 70.0f, .x_max = u + 15.0f, .y_max = v};
        }
        /* Every 5 s, the detector's glitches: a box with NaN edges, and a
         * box far above the image (a kite near the horizon). */
        if (f % 150u == 75u) {
            boxes[n_boxes++] = (GpecnetBox){
                .id = GLITCH, .x_min = NAN, .y_min = 500.0f, .x_max = NAN, .y_max = 560.0f};
            boxes[n_boxes++] = (GpecnetBox){
                .id = KITE, .x_min = 950.0f, .y_min = -3020.0f, .x_max = 970.0f, .y_max = -3000.0f};
        }

        /* One call: image -> NED ground, one status per box. */
        GpecnetDetection dets[MAX_BOXES];
        int32_t statuses[MAX_BOXES];
        size_t n_dets = 0;
        s = gpecnet_boxes_to_detections(&pose, boxes, n_boxes, dets, MAX_BOXES, statuses,
                                        &n_dets);
        if (s != GPECNET_OK) return fail("gpecnet_boxes_to_detections", s);
        for (size_t i = 0; i < n_boxes; i++) {
            if (statuses[i] == GPECNET_OK) continue;
            printf("t=%5u ms box id=%u refused (%d: %s)\n", (unsigned)t_ms,
                   (unsigned)boxes[i].id, (int)statuses[i], gpecnet_status_str(statuses[i]));
            refused++;
        }

        size_t n = 0;
        if (online_frame(ex.fc, ex.p, t_ms, dets, n_dets, out, &n) != 0) return 1;
        for (size_t i = 0; i < n; i++) {
            const GpecnetTrackForecast *o = &out[i];
            const float *end = o->point[GPECNET_ONLINE_HORIZONS - 1];
            float r90 = o->r90[GPECNET_ONLINE_HORIZONS - 1];
            uint32_t at_ms = o->end_ms + GPECNET_ONLINE_HORIZONS * 400u;
            float truth[2];
            pedestrian(o->id, (float)at_ms / 1000.0f, truth);
            float dn = end[0] - truth[0], de = end[1] - truth[1];
            sum_err += sqrtf(dn * dn + de * de);
            forecasts++;
            printf("t=%5u ms id=%u in 4.8 s: N %7.2f E %7.2f m, r90 %.2f m [%08x %08x %08x %08x "
                   "%08x | ",
                   (unsigned)o->end_ms, (unsigned)o->id, end[0], end[1], r90, (unsigned)o->id,
                   (unsigned)o->end_ms, (unsigned)bits(end[0]), (unsigned)bits(end[1]),
                   (unsigned)bits(r90));
            /* The endpoint drawn into the current image, if it is in view. */
            float uv[2];
            int32_t drawn = gpecnet_ground_to_image(&pose, end[0], end[1], uv);
            if (drawn == GPECNET_OK) {
                printf("%08x %08x] image (%.1f, %.1f) px\n", (unsigned)bits(uv[0]),
                       (unsigned)bits(uv[1]), uv[0], uv[1]);
            } else {
                printf("status %d] not in view\n", (int)drawn);
            }
        }
    }
    float mean = sum_err / (float)(forecasts > 0 ? forecasts : 1);
    printf("%u forecasts, mean endpoint error %.3f m (4.8 s ahead) [%08x], %u boxes refused\n",
           (unsigned)forecasts, mean, (unsigned)bits(mean), (unsigned)refused);
    free(ex.blob);
    return forecasts > 0 ? 0 : 1;
}
