/*
 * insncount: a QEMU TCG plugin that counts the guest instructions a run executes.
 *
 * Written for canopen-drive's benchmarks (scripts/bench.sh, benches/mcu-motion/run.sh): a
 * firmware in qemu-system-arm repeats the call it measures n and 2n times, and the difference
 * of two whole-run counts is the cost of n calls. The count is exact and the same on every
 * run, which wall-clock time in an emulator is not.
 *
 * Build:  gcc -O2 -shared -fPIC -fvisibility=hidden -o libinsncount.so insncount.c
 * Use:    qemu-system-arm ... -plugin ./libinsncount.so[,lo=ADDR,hi=ADDR][,begin=ADDR,end=ADDR] -d plugin
 *
 * At exit it prints one line (through QEMU's plugin log, hence `-d plugin`):
 *
 *     insncount: total <N> guest instructions; in [0x<lo>,0x<hi>): <M>
 *
 * N counts every instruction of every executed translation block (a block that starts counts
 * all its instructions: exceptions in the middle of a block are rare in the measured code and
 * are the same in every run). M counts only the instructions whose address is in [lo, hi)
 * (both 0 unless given: then M is 0), e.g. the address range of one function from `nm`.
 *
 * Marked intervals (`begin=ADDR,end=ADDR`, the addresses of two marker functions from `nm`; an
 * odd Thumb symbol value is taken as its even address): every time the block at `begin`
 * starts, the plugin notes N; every time the block at `end` starts, it closes the interval,
 * the instructions counted since. A firmware calls the two markers around the code it wants
 * counted one call at a time (drive-bench: one control tick each), and the plugin prints a
 * second line:
 *
 *     insncount: intervals <K>; first <F>; largest <L> (interval <I>); unmatched <U>
 *
 * K closed intervals, the first one's count F, the largest L and its number I (from 0), and U
 * markers out of order (an `end` without a `begin`, or two `begin`s; 0 in a sound run). Both
 * markers' blocks are counted the same way, so every interval holds the same constant share of
 * them: a firmware that first calls the pair with nothing between gets that share as F, and
 * L − F is then the code between the markers alone.
 *
 * It needs no QEMU headers: the few functions of the plugin API (qemu-plugin.h, API version
 * 1 as in QEMU 7.2) that it calls are declared below; QEMU resolves them when it loads the
 * plugin.
 */
#include <inttypes.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* --- The part of QEMU's plugin API this plugin uses ---------------------------------------- */

typedef uint64_t qemu_plugin_id_t;
typedef struct qemu_info_t qemu_info_t; /* only passed through */
struct qemu_plugin_tb;
struct qemu_plugin_insn;

enum qemu_plugin_op {
    QEMU_PLUGIN_INLINE_ADD_U64, /* *ptr += imm, executed in the translated code */
};

enum qemu_plugin_cb_flags {
    QEMU_PLUGIN_CB_NO_REGS, /* the callback reads no guest register */
};

typedef void (*qemu_plugin_vcpu_tb_trans_cb_t)(qemu_plugin_id_t id, struct qemu_plugin_tb *tb);
typedef void (*qemu_plugin_udata_cb_t)(qemu_plugin_id_t id, void *userdata);
typedef void (*qemu_plugin_vcpu_udata_cb_t)(unsigned int vcpu_index, void *userdata);

extern void qemu_plugin_register_vcpu_tb_trans_cb(qemu_plugin_id_t id, qemu_plugin_vcpu_tb_trans_cb_t cb);
extern void qemu_plugin_register_vcpu_tb_exec_inline(struct qemu_plugin_tb *tb, enum qemu_plugin_op op,
                                                     void *ptr, uint64_t imm);
extern void qemu_plugin_register_vcpu_insn_exec_inline(struct qemu_plugin_insn *insn, enum qemu_plugin_op op,
                                                       void *ptr, uint64_t imm);
extern void qemu_plugin_register_vcpu_tb_exec_cb(struct qemu_plugin_tb *tb, qemu_plugin_vcpu_udata_cb_t cb,
                                                 enum qemu_plugin_cb_flags flags, void *userdata);
extern size_t qemu_plugin_tb_n_insns(const struct qemu_plugin_tb *tb);
extern uint64_t qemu_plugin_tb_vaddr(const struct qemu_plugin_tb *tb);
extern struct qemu_plugin_insn *qemu_plugin_tb_get_insn(const struct qemu_plugin_tb *tb, size_t idx);
extern uint64_t qemu_plugin_insn_vaddr(const struct qemu_plugin_insn *insn);
extern void qemu_plugin_register_atexit_cb(qemu_plugin_id_t id, qemu_plugin_udata_cb_t cb, void *userdata);
extern void qemu_plugin_outs(const char *string);

#define EXPORTED __attribute__((visibility("default")))

/* QEMU refuses a plugin that does not say which API version it was written against. */
EXPORTED int qemu_plugin_version = 1;

/* --- The counters -------------------------------------------------------------------------- */

/* One guest CPU (the Cortex-M machines): plain counters, added to by the translated code. */
static uint64_t executed;
static uint64_t executed_in_range;
static uint64_t range_start;
static uint64_t range_end;

/* Marked intervals: the two marker addresses (0: none), the count when the open interval
 * began, and what the closed ones came to. */
static uint64_t mark_begin;
static uint64_t mark_end;
static int interval_open;
static uint64_t interval_began_at;
static uint64_t intervals;
static uint64_t first_interval;
static uint64_t largest_interval;
static uint64_t largest_at;
static uint64_t unmatched;

static int in_range(uint64_t address)
{
    return address >= range_start && address < range_end;
}

static void on_begin(unsigned int vcpu, void *userdata)
{
    (void)vcpu;
    (void)userdata;
    if (interval_open) {
        unmatched++;
    }
    interval_open = 1;
    interval_began_at = executed;
}

static void on_end(unsigned int vcpu, void *userdata)
{
    (void)vcpu;
    (void)userdata;
    if (!interval_open) {
        unmatched++;
        return;
    }
    interval_open = 0;
    uint64_t interval = executed - interval_began_at;
    if (intervals == 0) {
        first_interval = interval;
    }
    if (intervals == 0 || interval > largest_interval) {
        largest_interval = interval;
        largest_at = intervals;
    }
    intervals++;
}

/* Called once per translation of a block: attach the additions its executions make. */
static void on_translation(qemu_plugin_id_t id, struct qemu_plugin_tb *block)
{
    (void)id;
    size_t count = qemu_plugin_tb_n_insns(block);
    qemu_plugin_register_vcpu_tb_exec_inline(block, QEMU_PLUGIN_INLINE_ADD_U64, &executed, count);
    if (mark_begin != 0 || mark_end != 0) {
        uint64_t start = qemu_plugin_tb_vaddr(block);
        if (start == mark_begin) {
            qemu_plugin_register_vcpu_tb_exec_cb(block, on_begin, QEMU_PLUGIN_CB_NO_REGS, NULL);
        } else if (start == mark_end) {
            qemu_plugin_register_vcpu_tb_exec_cb(block, on_end, QEMU_PLUGIN_CB_NO_REGS, NULL);
        }
    }
    if (range_end <= range_start) {
        return;
    }
    for (size_t i = 0; i < count; i++) {
        struct qemu_plugin_insn *insn = qemu_plugin_tb_get_insn(block, i);
        if (in_range(qemu_plugin_insn_vaddr(insn))) {
            qemu_plugin_register_vcpu_insn_exec_inline(insn, QEMU_PLUGIN_INLINE_ADD_U64, &executed_in_range, 1);
        }
    }
}

static void report_at_exit(qemu_plugin_id_t id, void *userdata)
{
    (void)id;
    (void)userdata;
    char report[160];
    snprintf(report, sizeof report,
             "insncount: total %" PRIu64 " guest instructions; in [0x%" PRIx64 ",0x%" PRIx64 "): %" PRIu64 "\n",
             executed, range_start, range_end, executed_in_range);
    qemu_plugin_outs(report);
    if (mark_begin != 0 || mark_end != 0) {
        snprintf(report, sizeof report,
                 "insncount: intervals %" PRIu64 "; first %" PRIu64 "; largest %" PRIu64 " (interval %" PRIu64
                 "); unmatched %" PRIu64 "\n",
                 intervals, first_interval, largest_interval, largest_at, unmatched);
        qemu_plugin_outs(report);
    }
}

/* `name=value` with a number QEMU passed through from `-plugin lib.so,name=value`. */
static int parse_number(const char *argument, const char *name, uint64_t *value)
{
    size_t length = strlen(name);
    if (strncmp(argument, name, length) != 0 || argument[length] != '=') {
        return 0;
    }
    char *end = NULL;
    *value = strtoull(argument + length + 1, &end, 0);
    return end != NULL && *end == '\0';
}

EXPORTED int qemu_plugin_install(qemu_plugin_id_t id, const qemu_info_t *info, int argc, char **argv)
{
    (void)info;
    for (int i = 0; i < argc; i++) {
        if (!parse_number(argv[i], "lo", &range_start) && !parse_number(argv[i], "hi", &range_end)
            && !parse_number(argv[i], "begin", &mark_begin) && !parse_number(argv[i], "end", &mark_end)) {
            fprintf(stderr, "insncount: unknown argument '%s' (expected lo=, hi=, begin=, end=ADDR)\n", argv[i]);
            return -1;
        }
    }
    /* Thumb: the symbol's value has bit 0 set, the block starts at the even address. */
    mark_begin &= ~(uint64_t)1;
    mark_end &= ~(uint64_t)1;
    if ((mark_begin == 0) != (mark_end == 0) || (mark_begin != 0 && mark_begin == mark_end)) {
        fprintf(stderr, "insncount: begin= and end= go together, at two addresses\n");
        return -1;
    }
    qemu_plugin_register_vcpu_tb_trans_cb(id, on_translation);
    qemu_plugin_register_atexit_cb(id, report_at_exit, NULL);
    return 0;
}
