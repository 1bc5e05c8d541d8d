// Linked into the tools that bake (tools/CMakeLists.txt: cpvs_huge_pages). They link jemalloc, which then serves
// every malloc of the process (Mesa's included), and this asks it to back its memory with transparent huge
// pages. A bake allocates and frees hundreds of MB per region (read-back buffers, depth maps, tile chains, hash
// tables); on 4 KiB pages much of its time went to page faults (docs/construction.md, "Memory").
// Where the kernel has transparent huge pages off, jemalloc runs as usual.
extern "C" {
extern const char* malloc_conf;
const char* malloc_conf = "thp:always";
}
