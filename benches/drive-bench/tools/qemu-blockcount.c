/* Per-block execution counts of a qemu-system-arm run (TCG plugin API v1, QEMU 7.2), for the
 * Cortex-M4 profiles of benches/drive-bench/profile.py.
 * Build: gcc -O2 -shared -fPIC -fvisibility=hidden -o libblockcount.so qemu-blockcount.c
 * Use:   qemu-system-arm ... -plugin ./libblockcount.so,out=FILE -d plugin
 * Writes one line per translated block at exit: "<start address hex> <instructions> <executions>"
 * (a block translated twice has two lines). The same accounting as qemu-insncount.c: a block
 * counts all its instructions each time it starts. */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef uint64_t qemu_plugin_id_t;
struct qemu_plugin_tb;
typedef struct qemu_info_t qemu_info_t;
enum qemu_plugin_op { QEMU_PLUGIN_INLINE_ADD_U64 };
typedef void (*tb_trans_cb)(qemu_plugin_id_t, struct qemu_plugin_tb *);
typedef void (*udata_cb)(qemu_plugin_id_t, void *);
void qemu_plugin_register_vcpu_tb_trans_cb(qemu_plugin_id_t, tb_trans_cb);
void qemu_plugin_register_vcpu_tb_exec_inline(struct qemu_plugin_tb *, enum qemu_plugin_op, void *, uint64_t);
size_t qemu_plugin_tb_n_insns(const struct qemu_plugin_tb *);
uint64_t qemu_plugin_tb_vaddr(const struct qemu_plugin_tb *);
void qemu_plugin_register_atexit_cb(qemu_plugin_id_t, udata_cb, void *);

__attribute__((visibility("default"))) int qemu_plugin_version = 1;

struct block {
    uint64_t executions; /* first: the inline counter needs a stable address */
    uint64_t pc;
    uint64_t insns;
    struct block *next;
};

static struct block *blocks;
static char out_path[512] = "blockcount.txt";

static void tb_trans(qemu_plugin_id_t id, struct qemu_plugin_tb *tb) {
    struct block *b = calloc(1, sizeof *b);
    if (!b) return;
    b->pc = qemu_plugin_tb_vaddr(tb);
    b->insns = qemu_plugin_tb_n_insns(tb);
    b->next = blocks;
    blocks = b;
    qemu_plugin_register_vcpu_tb_exec_inline(tb, QEMU_PLUGIN_INLINE_ADD_U64, &b->executions, 1);
}

static void at_exit(qemu_plugin_id_t id, void *p) {
    FILE *f = fopen(out_path, "w");
    if (!f) return;
    for (struct block *b = blocks; b; b = b->next)
        if (b->executions)
            fprintf(f, "%llx %llu %llu\n", (unsigned long long)b->pc, (unsigned long long)b->insns,
                    (unsigned long long)b->executions);
    fclose(f);
}

__attribute__((visibility("default")))
int qemu_plugin_install(qemu_plugin_id_t id, const qemu_info_t *info, int argc, char **argv) {
    for (int i = 0; i < argc; i++)
        if (!strncmp(argv[i], "out=", 4)) snprintf(out_path, sizeof out_path, "%s", argv[i] + 4);
    qemu_plugin_register_vcpu_tb_trans_cb(id, tb_trans);
    qemu_plugin_register_atexit_cb(id, at_exit, NULL);
    return 0;
}
