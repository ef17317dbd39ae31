/* QEMU 7.2 TCG plugin (plugin API v1): exact guest-instruction count between
 * executions of two marker addresses.
 *   -plugin ./libinsn_window.so,start=0xADDR,end=0xADDR -d plugin -D log.txt
 * Prints: "window <n> insns <count>" for every start..end pair, and the total.
 * Optional ",profile=FILE[,base=0x08000000]": per-PC execution counts of
 * window 0 ("0xPC count" lines), to be folded into functions with the ELF's
 * symbol table (tools/profile.py).
 * Declarations are hand-copied from QEMU 7.2's include/qemu/qemu-plugin.h
 * (Debian ships no qemu-plugin.h and no contrib plugins). */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <stdbool.h>

typedef uint64_t qemu_plugin_id_t;
typedef struct qemu_info_t qemu_info_t;          /* only used by pointer */
struct qemu_plugin_tb;
struct qemu_plugin_insn;
enum qemu_plugin_cb_flags { QEMU_PLUGIN_CB_NO_REGS, QEMU_PLUGIN_CB_R_REGS, QEMU_PLUGIN_CB_RW_REGS };
enum qemu_plugin_op { QEMU_PLUGIN_INLINE_ADD_U64 };
typedef void (*qemu_plugin_vcpu_tb_trans_cb_t)(qemu_plugin_id_t id, struct qemu_plugin_tb *tb);
typedef void (*qemu_plugin_vcpu_udata_cb_t)(unsigned int vcpu_index, void *userdata);
typedef void (*qemu_plugin_udata_cb_t)(qemu_plugin_id_t id, void *userdata);
void qemu_plugin_register_vcpu_tb_trans_cb(qemu_plugin_id_t id, qemu_plugin_vcpu_tb_trans_cb_t cb);
void qemu_plugin_register_vcpu_insn_exec_cb(struct qemu_plugin_insn *insn, qemu_plugin_vcpu_udata_cb_t cb,
                                            enum qemu_plugin_cb_flags flags, void *userdata);
void qemu_plugin_register_vcpu_insn_exec_inline(struct qemu_plugin_insn *insn, enum qemu_plugin_op op,
                                                void *ptr, uint64_t imm);
size_t qemu_plugin_tb_n_insns(const struct qemu_plugin_tb *tb);
struct qemu_plugin_insn *qemu_plugin_tb_get_insn(const struct qemu_plugin_tb *tb, size_t idx);
uint64_t qemu_plugin_insn_vaddr(const struct qemu_plugin_insn *insn);
void qemu_plugin_register_atexit_cb(qemu_plugin_id_t id, qemu_plugin_udata_cb_t cb, void *userdata);
void qemu_plugin_outs(const char *string);

__attribute__((visibility("default"))) int qemu_plugin_version = 1;

static uint64_t total, t0, start_pc, end_pc;
static int windows;
static bool in_window;
/* optional per-PC profile of the first window (code in [base, base + 4 MiB);
 * base=0x08000000 for the STM32F405 flash) */
#define PROF_SPAN (4u << 20)
static uint64_t prof_base;
static uint64_t *counts, *snap;
static const char *prof_path;

static void on_start(unsigned int vcpu, void *u)
{
    (void)vcpu; (void)u;
    t0 = total; in_window = true;
    if (counts && windows == 0) memcpy(snap, counts, (PROF_SPAN / 2) * sizeof *counts);
}
static void on_end(unsigned int vcpu, void *u)
{
    (void)vcpu; (void)u;
    if (!in_window) return;
    in_window = false;
    char buf[96];
    snprintf(buf, sizeof buf, "window %d insns %llu\n", windows, (unsigned long long)(total - t0));
    qemu_plugin_outs(buf);
    if (counts && windows == 0) {
        FILE *f = fopen(prof_path, "w");
        for (uint32_t i = 0; f && i < PROF_SPAN / 2; i++)
            if (counts[i] != snap[i])
                fprintf(f, "0x%llx %llu\n", (unsigned long long)(prof_base + i * 2), (unsigned long long)(counts[i] - snap[i]));
        if (f) fclose(f);
    }
    windows++;
}

static void tb_trans(qemu_plugin_id_t id, struct qemu_plugin_tb *tb)
{
    (void)id;
    size_t n = qemu_plugin_tb_n_insns(tb);
    for (size_t i = 0; i < n; i++) {
        struct qemu_plugin_insn *insn = qemu_plugin_tb_get_insn(tb, i);
        uint64_t pc = qemu_plugin_insn_vaddr(insn);
        /* callbacks run before the instruction executes; the marker insn
         * itself is counted after the snapshot in on_start. */
        if (pc == start_pc)
            qemu_plugin_register_vcpu_insn_exec_cb(insn, on_start, QEMU_PLUGIN_CB_NO_REGS, NULL);
        if (pc == end_pc)
            qemu_plugin_register_vcpu_insn_exec_cb(insn, on_end, QEMU_PLUGIN_CB_NO_REGS, NULL);
        qemu_plugin_register_vcpu_insn_exec_inline(insn, QEMU_PLUGIN_INLINE_ADD_U64, &total, 1);
        if (counts && pc >= prof_base && pc - prof_base < PROF_SPAN)
            qemu_plugin_register_vcpu_insn_exec_inline(insn, QEMU_PLUGIN_INLINE_ADD_U64, &counts[(pc - prof_base) / 2], 1);
    }
}

static void at_exit(qemu_plugin_id_t id, void *u)
{
    (void)id; (void)u;
    char buf[64];
    snprintf(buf, sizeof buf, "total insns %llu\n", (unsigned long long)total);
    qemu_plugin_outs(buf);
}

__attribute__((visibility("default")))
int qemu_plugin_install(qemu_plugin_id_t id, const qemu_info_t *info, int argc, char **argv)
{
    (void)info;
    for (int i = 0; i < argc; i++) {
        if (!strncmp(argv[i], "start=", 6)) start_pc = strtoull(argv[i] + 6, NULL, 0) & ~1ULL;
        else if (!strncmp(argv[i], "end=", 4)) end_pc = strtoull(argv[i] + 4, NULL, 0) & ~1ULL;
        else if (!strncmp(argv[i], "profile=", 8)) prof_path = argv[i] + 8;
        else if (!strncmp(argv[i], "base=", 5)) prof_base = strtoull(argv[i] + 5, NULL, 0);
    }
    if (prof_path) {
        counts = calloc(PROF_SPAN / 2, sizeof *counts);
        snap = calloc(PROF_SPAN / 2, sizeof *snap);
    }
    qemu_plugin_register_vcpu_tb_trans_cb(id, tb_trans);
    qemu_plugin_register_atexit_cb(id, at_exit, NULL);
    return 0;
}
