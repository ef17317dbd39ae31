/* What the C examples of this folder share: the bits of a float as they
 * print them, reading a file whole, the message of a failed call, and the
 * online examples' start and camera frame.
 *
 * Static inline functions only, so that each example stays one translation
 * unit and compiles with the command line in its opening comment: the
 * quoted `#include "common.h"` is looked up in the including file's folder
 * first, so no `-I` for this folder is needed. An example that does not call
 * one of these functions gets no code and no warning for it. */
#ifndef GPECNET_EXAMPLES_COMMON_H
#define GPECNET_EXAMPLES_COMMON_H

#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "gpecnet.h"

/* The bits of `v`: the examples print them beside the value, so that
 * `ffi/tests/c_examples.rs` compares them with the Rust core's exactly. */
static inline uint32_t bits(float v) {
    uint32_t u;
    memcpy(&u, &v, sizeof u);
    return u;
}

/* The file at `path`, whole, in a buffer from malloc (the caller frees it),
 * its size in `*len`; NULL when it cannot be opened or read, or is empty. */
static inline unsigned char *read_file(const char *path, size_t *len) {
    FILE *f = fopen(path, "rb");
    if (!f) return NULL;
    fseek(f, 0, SEEK_END);
    long n = ftell(f);
    fseek(f, 0, SEEK_SET);
    unsigned char *buf = n > 0 ? malloc((size_t)n) : NULL;
    if (buf && fread(buf, 1, (size_t)n, f) != (size_t)n) {
        free(buf);
        buf = NULL;
    }
    fclose(f);
    *len = (size_t)n;
    return buf;
}

/* The model file at `path`, whole (see read_file); prints `cannot read
 * PATH` to stderr and returns NULL when it cannot. The blob must outlive
 * the predictor made from it: the library reads it in place. */
static inline unsigned char *read_model(const char *path, size_t *len) {
    unsigned char *blob = read_file(path, len);
    if (!blob) fprintf(stderr, "cannot read %s\n", path);
    return blob;
}

/* Prints the failed call `what` with its status `s` to stderr, as
 * `what: message (code)`; returns 1, the examples' exit code for it. */
static inline int fail(const char *what, int32_t s) {
    fprintf(stderr, "%s: %s (%d)\n", what, gpecnet_status_str(s), (int)s);
    return 1;
}

/* What the online examples run on, from online_start. */
typedef struct OnlineExample {
    /* The model file, whole: free it at the end, not before (the predictor
     * reads it in place). */
    unsigned char *blob;
    /* The predictor, in metres, in the caller's storage. */
    GpecnetPredictor *p;
    /* The forecaster, in the caller's storage. */
    GpecnetForecaster *fc;
    /* The forecaster's configuration: the loop's defaults in metres. */
    GpecnetOnlineConfig cfg;
} OnlineExample;

/* The online examples' start, from their one argument, MODEL.gpec: the
 * blob read whole, a predictor in metres in `predictor_mem` and a
 * forecaster with the loop's defaults in `forecaster_mem`, 1 s without a
 * detection ending a track, all in `*ex`. The storage is the caller's, of
 * the sizes and alignments gpecnet.h names. Returns 0 when both are ready,
 * else the exit code after printing why: 2 for the command line or an
 * unreadable file, 1 for a failed call. */
static inline int online_start(int argc, char **argv, void *predictor_mem, size_t predictor_len,
                               void *forecaster_mem, size_t forecaster_len, OnlineExample *ex) {
    if (argc != 2) {
        fprintf(stderr, "usage: %s MODEL.gpec\n", argv[0]);
        return 2;
    }
    size_t blob_len = 0;
    ex->blob = read_model(argv[1], &blob_len);
    if (!ex->blob) return 2;
    int32_t s = gpecnet_init_units(predictor_mem, predictor_len, ex->blob, blob_len,
                                   GPECNET_UNIT_METRES, 0.0f);
    if (s != GPECNET_OK) return fail("gpecnet_init_units", s);
    ex->p = (GpecnetPredictor *)predictor_mem;
    gpecnet_online_config_default(&ex->cfg);
    s = gpecnet_forecaster_init(forecaster_mem, forecaster_len, ex->p, &ex->cfg, 1000);
    if (s != GPECNET_OK) return fail("gpecnet_forecaster_init", s);
    ex->fc = (GpecnetForecaster *)forecaster_mem;
    return 0;
}

/* One camera frame at `t_ms` through the forecaster `fc`: the forecasts of
 * the tracks that gained a grid point in `out` (room for
 * GPECNET_ONLINE_TRACKS), `*n` of them. Returns 0, or 1 after printing the
 * failed call or the status of the first track whose forecast failed. */
static inline int online_frame(GpecnetForecaster *fc, GpecnetPredictor *p, uint32_t t_ms,
                               const GpecnetDetection *dets, size_t n_dets,
                               GpecnetTrackForecast *out, size_t *n) {
    GpecnetOnlineReport rep;
    int32_t s = gpecnet_forecaster_frame(fc, p, t_ms, dets, n_dets, out, GPECNET_ONLINE_TRACKS,
                                         n, &rep);
    if (s != GPECNET_OK) return fail("gpecnet_forecaster_frame", s);
    if (rep.failed > 0) return fail("a track's forecast", rep.first_error);
    return 0;
}

#endif /* GPECNET_EXAMPLES_COMMON_H */
