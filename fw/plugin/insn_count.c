/*
 * insn_count: a QEMU TCG plugin that counts guest instructions between two marker functions.
 *
 * Usage (QEMU 7.2, Debian):
 *   gcc -shared -fPIC -O2 -o libinsn_count.so insn_count.c
 *   qemu-system-arm ... -plugin ./libinsn_count.so,begin=0xADDR,end=0xADDR -d plugin -D log.txt
 *
 * `begin` and `end` are the (even) entry addresses of the firmware's `fw_region_begin` and
 * `fw_region_end`. Every executed translation block adds its instruction count to a counter
 * (an inline add, no helper call); when the first instruction of `begin` runs, the counter is
 * pushed on a small stack; when `end` runs, the difference is printed:
 *   insn_count <n> <instructions>
 * numbered in the order the regions close. A block adds its whole length when it starts, so a
 * region includes the tail of the `begin` block and all of the `end` block: a fixed overhead of
 * a few instructions, the same for every region (measure it with an empty region).
 *
 * With `profile=PATH` it also counts the executions of every translation block (one more
 * inline add per block) and writes, at exit, one line per block to PATH:
 *   <start address hex> <instructions in the block> <executions>
 * (a block translated twice appears twice; `scripts/arm-profile.sh` sums them per function).
 *
 * Debian ships no qemu-plugin.h, so the few API functions used are declared here by hand, as
 * QEMU 7.2 defines them (plugin API version 1; QEMU 8+ changed signatures and wants version 2).
 */
#include <inttypes.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef uint64_t qemu_plugin_id_t;
typedef struct qemu_info_t qemu_info_t; /* only passed through */
struct qemu_plugin_tb;
struct qemu_plugin_insn;

enum qemu_plugin_cb_flags { QEMU_PLUGIN_CB_NO_REGS, QEMU_PLUGIN_CB_R_REGS, QEMU_PLUGIN_CB_RW_REGS };
enum qemu_plugin_op { QEMU_PLUGIN_INLINE_ADD_U64 };

typedef void (*qemu_plugin_vcpu_tb_trans_cb_t)(qemu_plugin_id_t id, struct qemu_plugin_tb *tb);
typedef void (*qemu_plugin_vcpu_udata_cb_t)(unsigned int vcpu_index, void *userdata);
typedef void (*qemu_plugin_udata_cb_t)(qemu_plugin_id_t id, void *userdata);

void qemu_plugin_register_vcpu_tb_trans_cb(qemu_plugin_id_t id, qemu_plugin_vcpu_tb_trans_cb_t cb);
void qemu_plugin_register_vcpu_tb_exec_inline(struct qemu_plugin_tb *tb, enum qemu_plugin_op op, void *ptr,
                                              uint64_t imm);
void qemu_plugin_register_vcpu_insn_exec_cb(struct qemu_plugin_insn *insn, qemu_plugin_vcpu_udata_cb_t cb,
                                            enum qemu_plugin_cb_flags flags, void *userdata);
size_t qemu_plugin_tb_n_insns(const struct qemu_plugin_tb *tb);
struct qemu_plugin_insn *qemu_plugin_tb_get_insn(const struct qemu_plugin_tb *tb, size_t idx);
uint64_t qemu_plugin_insn_vaddr(const struct qemu_plugin_insn *insn);
void qemu_plugin_outs(const char *string);
void qemu_plugin_register_atexit_cb(qemu_plugin_id_t id, qemu_plugin_udata_cb_t cb, void *userdata);

__attribute__((visibility("default"))) int qemu_plugin_version = 1;

#define MAX_DEPTH 16

static uint64_t begin_addr, end_addr;
static uint64_t counter; /* instructions executed so far (whole translation blocks) */
static uint64_t stack[MAX_DEPTH];
static int depth;
static uint64_t closed; /* regions reported */
static int errors;

/* Profile mode: one slot per translated block, allocated in chunks, never freed. */
struct tb_slot {
    uint64_t pc;
    uint64_t insns;
    uint64_t execs;
};
#define SLOTS_PER_CHUNK 4096
struct slot_chunk {
    struct tb_slot slots[SLOTS_PER_CHUNK];
    size_t used;
    struct slot_chunk *next;
};
static const char *profile_path;
static struct slot_chunk *chunks;

static struct tb_slot *new_slot(void)
{
    if (chunks == NULL || chunks->used == SLOTS_PER_CHUNK) {
        struct slot_chunk *c = calloc(1, sizeof *c);
        if (c == NULL) {
            errors++;
            return NULL;
        }
        c->next = chunks;
        chunks = c;
    }
    return &chunks->slots[chunks->used++];
}

static void on_begin(unsigned int vcpu, void *udata)
{
    (void)vcpu;
    (void)udata;
    if (depth < MAX_DEPTH) {
        stack[depth] = counter;
    } else {
        errors++;
    }
    depth++;
}

static void on_end(unsigned int vcpu, void *udata)
{
    char line[96];
    (void)vcpu;
    (void)udata;
    if (depth <= 0) {
        errors++;
        qemu_plugin_outs("insn_count error: end marker without begin\n");
        return;
    }
    depth--;
    if (depth < MAX_DEPTH) {
        snprintf(line, sizeof line, "insn_count %" PRIu64 " %" PRIu64 "\n", closed, counter - stack[depth]);
        qemu_plugin_outs(line);
    }
    closed++;
}

static void on_tb_trans(qemu_plugin_id_t id, struct qemu_plugin_tb *tb)
{
    size_t n = qemu_plugin_tb_n_insns(tb);
    (void)id;
    qemu_plugin_register_vcpu_tb_exec_inline(tb, QEMU_PLUGIN_INLINE_ADD_U64, &counter, n);
    if (profile_path != NULL && n > 0) {
        struct tb_slot *slot = new_slot();
        if (slot != NULL) {
            slot->pc = qemu_plugin_insn_vaddr(qemu_plugin_tb_get_insn(tb, 0));
            slot->insns = n;
            qemu_plugin_register_vcpu_tb_exec_inline(tb, QEMU_PLUGIN_INLINE_ADD_U64, &slot->execs, 1);
        }
    }
    for (size_t i = 0; i < n; i++) {
        struct qemu_plugin_insn *insn = qemu_plugin_tb_get_insn(tb, i);
        uint64_t pc = qemu_plugin_insn_vaddr(insn);
        if (pc == begin_addr) {
            qemu_plugin_register_vcpu_insn_exec_cb(insn, on_begin, QEMU_PLUGIN_CB_NO_REGS, NULL);
        } else if (pc == end_addr) {
            qemu_plugin_register_vcpu_insn_exec_cb(insn, on_end, QEMU_PLUGIN_CB_NO_REGS, NULL);
        }
    }
}

static void on_exit_cb(qemu_plugin_id_t id, void *udata)
{
    char line[128];
    (void)id;
    (void)udata;
    snprintf(line, sizeof line, "insn_count total %" PRIu64 " regions %" PRIu64 " open %d errors %d\n", counter,
             closed, depth, errors);
    qemu_plugin_outs(line);
    if (profile_path != NULL) {
        FILE *f = fopen(profile_path, "w");
        if (f == NULL) {
            qemu_plugin_outs("insn_count error: cannot write the profile\n");
            return;
        }
        for (struct slot_chunk *c = chunks; c != NULL; c = c->next) {
            for (size_t i = 0; i < c->used; i++) {
                const struct tb_slot *t = &c->slots[i];
                if (t->execs > 0) {
                    fprintf(f, "%" PRIx64 " %" PRIu64 " %" PRIu64 "\n", t->pc, t->insns, t->execs);
                }
            }
        }
        fclose(f);
    }
}

__attribute__((visibility("default"))) int qemu_plugin_install(qemu_plugin_id_t id, const qemu_info_t *info,
                                                                int argc, char **argv)
{
    (void)info;
    for (int i = 0; i < argc; i++) {
        const char *arg = argv[i];
        if (strncmp(arg, "begin=", 6) == 0) {
            begin_addr = strtoull(arg + 6, NULL, 0) & ~(uint64_t)1; /* drop the Thumb bit */
        } else if (strncmp(arg, "end=", 4) == 0) {
            end_addr = strtoull(arg + 4, NULL, 0) & ~(uint64_t)1;
        } else if (strncmp(arg, "profile=", 8) == 0) {
            profile_path = arg + 8;
        } else {
            fprintf(stderr, "insn_count: unknown argument %s (want begin=ADDR,end=ADDR[,profile=PATH])\n", arg);
            return -1;
        }
    }
    if (begin_addr == 0 || end_addr == 0 || begin_addr == end_addr) {
        fprintf(stderr, "insn_count: need distinct begin=ADDR and end=ADDR\n");
        return -1;
    }
    qemu_plugin_register_vcpu_tb_trans_cb(id, on_tb_trans);
    qemu_plugin_register_atexit_cb(id, on_exit_cb, NULL);
    return 0;
}
