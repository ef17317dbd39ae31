/* The golden replay on a Cortex-M4F (STM32F405, QEMU netduinoplus2), in C,
 * through the thumbv7em-none-eabihf staticlib of gpecnet-ffi.
 *
 * The blob and its golden file are linked into flash (objcopy -I binary:
 * _binary_blob_bin_* and _binary_golden_bin_*) and read in place; the
 * predictor lives in a static buffer. Output and exit code go through ARM
 * semihosting: exit 0 only when every endpoint and point-forecast value
 * matches the golden file bit for bit. Built and run by `cargo xtask ffi-arm`
 * (arm-none-eabi-gcc + newlib-nano, link.ld beside this file). No rdimon, no
 * malloc: the startup code below is the whole runtime. */
#include <stdalign.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include "gpecnet.h"

extern const uint8_t _binary_blob_bin_start[], _binary_blob_bin_end[];
extern const uint8_t _binary_golden_bin_start[], _binary_golden_bin_end[];

/* ---- semihosting (QEMU -semihosting-config enable=on,target=native) ---- */
static int semihost(int op, const void *arg) {
    register int r0 __asm__("r0") = op;
    register const void *r1 __asm__("r1") = arg;
    __asm__ volatile("bkpt 0xAB" : "+r"(r0) : "r"(r1) : "memory");
    return r0;
}
static void put(const char *s) { semihost(0x04 /* SYS_WRITE0 */, s); }
static void __attribute__((noreturn)) sh_exit(int ok) {
    /* ADP_Stopped_ApplicationExit -> QEMU exits 0; RunTimeErrorUnknown -> 1. */
    semihost(0x18 /* SYS_EXIT */, (const void *)(ok ? 0x20026 : 0x20023));
    for (;;) {
    }
}

/* ---- the replay ---- */
static alignas(GPECNET_PREDICTOR_ALIGN) uint8_t storage[GPECNET_PREDICTOR_SIZE];
static GpecnetGoldenCase c;
static char line[160];

static int same_bits(const float *a, const float *b) { return memcmp(a, b, 2 * sizeof(float)) == 0; }

int main(void) {
    const uint8_t *blob = _binary_blob_bin_start;
    size_t blob_len = (size_t)(_binary_blob_bin_end - _binary_blob_bin_start);
    const uint8_t *golden = _binary_golden_bin_start;
    size_t golden_len = (size_t)(_binary_golden_bin_end - _binary_golden_bin_start);

    int32_t s = gpecnet_init(storage, sizeof storage, blob, blob_len);
    if (s != GPECNET_OK) {
        snprintf(line, sizeof line, "gpecnet_init: %s\n", gpecnet_status_str(s));
        put(line);
        return 1;
    }
    GpecnetPredictor *p = (GpecnetPredictor *)storage;
    GpecnetModelInfo info;
    GpecnetGoldenInfo g;
    gpecnet_model_info(p, &info);
    s = gpecnet_golden_info(golden, golden_len, &g);
    if (s != GPECNET_OK || g.model_crc != info.crc) {
        put("golden file unreadable or for other weights\n");
        return 1;
    }
    unsigned long values = 0, bad = 0, failed = 0;
    for (uint32_t i = 0; i < g.n_cases; i++) {
        if (gpecnet_golden_case(golden, golden_len, i, &c) != GPECNET_OK) return 1;
        float ends[GPECNET_GOLDEN_MAX_K][2];
        s = gpecnet_predict_endpoints(p, &c.past_xy[0][0], c.past_len, c.seed, &ends[0][0], c.k);
        if (s != GPECNET_OK) {
            failed++;
            continue;
        }
        for (uint32_t e = 0; e < c.k; e++, values++) bad += !same_bits(ends[e], c.endpoints_xy[e]);
        if (c.point_len > 0) {
            float point[GPECNET_MAX_FUTURE][2];
            size_t n = 0;
            s = gpecnet_predict_point(p, &c.past_xy[0][0], c.past_len, &point[0][0], GPECNET_MAX_FUTURE, &n);
            if (s != GPECNET_OK || n != c.point_len) {
                failed++;
                continue;
            }
            for (size_t t = 0; t < n; t++, values++) bad += !same_bits(point[t], c.point_xy[t]);
        }
    }
    snprintf(line, sizeof line, "arm %s (%s): %lu cases, %lu values, %lu differ, %lu calls failed\n",
             info.name, g.sine, (unsigned long)g.n_cases, values, bad, failed);
    put(line);
    return (bad == 0 && failed == 0 && values > 0) ? 0 : 1;
}

/* ---- startup: vector table, FPU on, .bss zeroed, main, semihosting exit ---- */
extern uint32_t __bss_start__, __bss_end__, _estack;

void Reset_Handler(void) {
    *(volatile uint32_t *)0xE000ED88u |= 0xFu << 20; /* CPACR: CP10/CP11 full access */
    __asm__ volatile("dsb\n isb");
    for (uint32_t *w = &__bss_start__; w < &__bss_end__; w++) *w = 0;
    sh_exit(main() == 0);
}

static void Fault_Handler(void) {
    put("fault\n");
    sh_exit(0);
}

__attribute__((section(".isr_vector"), used)) static const void *const vectors[16] = {
    &_estack,      (const void *)Reset_Handler, (const void *)Fault_Handler, (const void *)Fault_Handler,
    (const void *)Fault_Handler, (const void *)Fault_Handler, (const void *)Fault_Handler,
};
