/* A QEMU TCG plugin that counts the guest instructions a program executes under qemu-user: the work an
 * emulated ARM64 program does, which qemu's run time does not measure (benchmarks/arm64_lookup_work.py).
 *
 *   qemu-aarch64 -plugin ./qemu_instruction_count.so,out=COUNT.txt[,functions=on] PROGRAM ARGS
 *
 * writes the count to COUNT.txt when the program exits; with functions=on, then one line per function of the
 * program (its symbol, from the ELF symbol table: build without -s), most instructions first: the count and
 * the name. Each translated block adds its instruction count to a 64-bit counter of its own, inline, each time
 * it runs (a single-threaded guest: the benchmark programs are); the blocks are summed at exit.
 *
 * Written against QEMU's plugin API version 1 (QEMU 4.2 to 8.x; Debian 12 ships 7.2), whose few declarations it
 * needs are repeated here: Debian does not package qemu-plugin.h. */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef uint64_t qemu_plugin_id_t;
struct qemu_plugin_tb;
struct qemu_plugin_insn;
typedef struct qemu_info_t qemu_info_t;
enum qemu_plugin_op { QEMU_PLUGIN_INLINE_ADD_U64 };
typedef void (*qemu_plugin_vcpu_tb_trans_cb_t)(qemu_plugin_id_t id, struct qemu_plugin_tb* tb);
typedef void (*qemu_plugin_udata_cb_t)(qemu_plugin_id_t id, void* userdata);
void qemu_plugin_register_vcpu_tb_trans_cb(qemu_plugin_id_t id, qemu_plugin_vcpu_tb_trans_cb_t cb);
void qemu_plugin_register_vcpu_tb_exec_inline(struct qemu_plugin_tb* tb, enum qemu_plugin_op op, void* ptr,
                                              uint64_t imm);
size_t qemu_plugin_tb_n_insns(const struct qemu_plugin_tb* tb);
struct qemu_plugin_insn* qemu_plugin_tb_get_insn(const struct qemu_plugin_tb* tb, size_t idx);
const char* qemu_plugin_insn_symbol(const struct qemu_plugin_insn* insn);
void qemu_plugin_register_atexit_cb(qemu_plugin_id_t id, qemu_plugin_udata_cb_t cb, void* userdata);

__attribute__((visibility("default"))) int qemu_plugin_version = 1;

/* One translated block: its counter and the function its first instruction is in. Never freed or moved (the
 * inline additions hold the counter's address). */
struct block {
  uint64_t executed;
  const char* symbol;
  struct block* next;
};
static struct block* blocks;
static char output[4096];
static int byFunction;

static void translated(qemu_plugin_id_t id, struct qemu_plugin_tb* tb) {
  (void)id;
  struct block* b = calloc(1, sizeof *b);
  if (!b) abort();
  const char* symbol = qemu_plugin_insn_symbol(qemu_plugin_tb_get_insn(tb, 0));
  b->symbol = symbol ? symbol : "?";
  b->next = blocks;
  blocks = b;
  qemu_plugin_register_vcpu_tb_exec_inline(tb, QEMU_PLUGIN_INLINE_ADD_U64, &b->executed, qemu_plugin_tb_n_insns(tb));
}

struct function {
  const char* symbol;
  uint64_t executed;
};
static int mostFirst(const void* a, const void* b) {
  const uint64_t x = ((const struct function*)a)->executed, y = ((const struct function*)b)->executed;
  return x < y ? 1 : x > y ? -1 : strcmp(((const struct function*)a)->symbol, ((const struct function*)b)->symbol);
}

static void finished(qemu_plugin_id_t id, void* userdata) {
  (void)id, (void)userdata;
  uint64_t executed = 0;
  size_t count = 0;
  for (struct block* b = blocks; b; b = b->next) executed += b->executed, ++count;
  FILE* f = output[0] ? fopen(output, "w") : stderr;
  if (!f) return;
  fprintf(f, "%llu\n", (unsigned long long)executed);
  if (byFunction) {  /* the blocks summed per symbol (symbols are interned by qemu: equal names, one pointer) */
    struct function* functions = calloc(count + 1, sizeof *functions);
    size_t n = 0;
    for (struct block* b = blocks; b && functions; b = b->next) {
      size_t i = 0;
      while (i < n && strcmp(functions[i].symbol, b->symbol) != 0) ++i;
      if (i == n) functions[n++].symbol = b->symbol;
      functions[i].executed += b->executed;
    }
    if (functions) qsort(functions, n, sizeof *functions, mostFirst);
    for (size_t i = 0; functions && i < n && functions[i].executed > 0; ++i)
      fprintf(f, "%llu %s\n", (unsigned long long)functions[i].executed, functions[i].symbol);
    free(functions);
  }
  if (f != stderr) fclose(f);
}

__attribute__((visibility("default"))) int qemu_plugin_install(qemu_plugin_id_t id, const qemu_info_t* info,
                                                               int argc, char** argv) {
  (void)info;
  for (int i = 0; i < argc; ++i)
    if (strncmp(argv[i], "out=", 4) == 0) snprintf(output, sizeof output, "%s", argv[i] + 4);
    else if (strcmp(argv[i], "functions=on") == 0) byFunction = 1;
  qemu_plugin_register_vcpu_tb_trans_cb(id, translated);
  qemu_plugin_register_atexit_cb(id, finished, NULL);
  return 0;
}
