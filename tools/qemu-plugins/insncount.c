/*
 * insncount: a QEMU TCG plugin that counts the guest instructions a run executes.
 *
 * Written for canopen-drive's benchmarks (scripts/bench.sh, benches/mcu-motion/run.sh): a
 * firmware in qemu-system-arm repeats the call it measures n and 2n times, and the difference
 * of two whole-run counts is the cost of n calls. The count is exact and the same on every
 * run, which wall-clock time in an emulator is not.
 *
 * Build:  gcc -O2 -shared -fPIC -fvisibility=hidden -o libinsncount.so insncount.c
 * Use:    qemu-system-arm ... -plugin ./libinsncount.so[,lo=ADDR,hi=ADDR] -d plugin
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

typedef void (*qemu_plugin_vcpu_tb_trans_cb_t)(qemu_plugin_id_t id, struct qemu_plugin_tb *tb);
typedef void (*qemu_plugin_udata_cb_t)(qemu_plugin_id_t id, void *userdata);

extern void qemu_plugin_register_vcpu_tb_trans_cb(qemu_plugin_id_t id, qemu_plugin_vcpu_tb_trans_cb_t cb);
extern void qemu_plugin_register_vcpu_tb_exec_inline(struct qemu_plugin_tb *tb, enum qemu_plugin_op op,
                                                     void *ptr, uint64_t imm);
extern void qemu_plugin_register_vcpu_insn_exec_inline(struct qemu_plugin_insn *insn, enum qemu_plugin_op op,
                                                       void *ptr, uint64_t imm);
extern size_t qemu_plugin_tb_n_insns(const struct qemu_plugin_tb *tb);
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

static int in_range(uint64_t address)
{
    return address >= range_start && address < range_end;
}

/* Called once per translation of a block: attach the additions its executions make. */
static void on_translation(qemu_plugin_id_t id, struct qemu_plugin_tb *block)
{
    (void)id;
    size_t count = qemu_plugin_tb_n_insns(block);
    qemu_plugin_register_vcpu_tb_exec_inline(block, QEMU_PLUGIN_INLINE_ADD_U64, &executed, count);
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
        if (!parse_number(argv[i], "lo", &range_start) && !parse_number(argv[i], "hi", &range_end)) {
            fprintf(stderr, "insncount: unknown argument '%s' (expected lo=ADDR, hi=ADDR)\n", argv[i]);
            return -1;
        }
    }
    qemu_plugin_register_vcpu_tb_trans_cb(id, on_translation);
    qemu_plugin_register_atexit_cb(id, report_at_exit, NULL);
    return 0;
}
