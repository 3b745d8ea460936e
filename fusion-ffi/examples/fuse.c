/*
 * fuse: fuse a visible and a thermal PGM with the fusion core's C interface.
 *
 *   fuse VIS.pgm TIR.pgm OUT.pgm adf|tsifsd|ifevip|adaptive [flight|classic] [strips]
 *
 * Reads two binary 8-bit PGM (P5) files, upscales the thermal frame onto the visible grid
 * (bicubic) when their sizes differ, fuses them and writes OUT.pgm (the same bytes as
 * `fusion fuse VIS.pgm TIR.pgm OUT.pgm --method M --variant V`). With `strips` it fuses in the
 * 512 KiB strip working set instead of a whole-frame scratch: the same bytes.
 *
 * The same file builds for a host (cc, against libfusion_ffi.a) and for a Cortex-M7 under
 * QEMU (arm-none-eabi-gcc with newlib's semihosting, which gives fopen/fread on the host's
 * files); see fusion-ffi/README.md. Exit status: 0 fused, 1 an error (one line on stderr),
 * 2 a usage error.
 */
#include "fusion.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Skips whitespace and '#' comments between PGM header fields. */
static int skip_space(FILE *f) {
  int c = fgetc(f);
  for (;;) {
    if (c == '#') {
      while (c != '\n' && c != EOF) c = fgetc(f);
    } else if (c == ' ' || c == '\t' || c == '\r' || c == '\n') {
      c = fgetc(f);
    } else {
      return c;
    }
  }
}

/* One unsigned decimal header field; -1 when there is none. */
static long read_field(FILE *f) {
  int c = skip_space(f);
  long v = -1;
  while (c >= '0' && c <= '9') {
    v = (v < 0 ? 0 : v) * 10 + (c - '0');
    if (v > 1L << 24) return -1;
    c = fgetc(f);
  }
  return v; /* the one whitespace byte after maxval is consumed here */
}

/* Reads an 8-bit binary PGM into a new buffer; NULL (with a message) on failure. */
static unsigned char *read_pgm(const char *path, size_t *w, size_t *h) {
  FILE *f = fopen(path, "rb");
  if (!f) {
    fprintf(stderr, "fuse: cannot open %s\n", path);
    return NULL;
  }
  unsigned char *data = NULL;
  long width, height, maxval;
  if (fgetc(f) != 'P' || fgetc(f) != '5') {
    fprintf(stderr, "fuse: %s is not a binary PGM (P5)\n", path);
  } else if ((width = read_field(f)) <= 0 || (height = read_field(f)) <= 0 ||
             (maxval = read_field(f)) != 255) {
    fprintf(stderr, "fuse: %s: need a positive size and maxval 255\n", path);
  } else if (!(data = malloc((size_t)width * (size_t)height))) {
    fprintf(stderr, "fuse: %s: out of memory for %ldx%ld\n", path, width, height);
  } else if (fread(data, 1, (size_t)width * (size_t)height, f) != (size_t)width * (size_t)height) {
    fprintf(stderr, "fuse: %s: truncated pixel data\n", path);
    free(data);
    data = NULL;
  } else {
    *w = (size_t)width;
    *h = (size_t)height;
  }
  fclose(f);
  return data;
}

/* Writes an 8-bit binary PGM; the header as the fusion CLI writes it. */
static int write_pgm(const char *path, const unsigned char *data, size_t w, size_t h) {
  FILE *f = fopen(path, "wb");
  if (!f) {
    fprintf(stderr, "fuse: cannot create %s\n", path);
    return 1;
  }
  int ok = fprintf(f, "P5\n%u %u 255\n", (unsigned)w, (unsigned)h) > 0 && fwrite(data, 1, w * h, f) == w * h;
  ok = (fclose(f) == 0) && ok;
  if (!ok) fprintf(stderr, "fuse: writing %s failed\n", path);
  return ok ? 0 : 1;
}

/* One line naming what the core refused. */
static int fail(const char *what, const FusionError *e) {
  fprintf(stderr, "fuse: %s: %s", what, fusion_status_text(e->status));
  if (e->status == FUSION_STATUS_INVALID_PARAMETER) fprintf(stderr, " (%s)", e->name);
  if (e->status == FUSION_STATUS_SIZE_MISMATCH)
    fprintf(stderr, " (expected %ux%u, got %ux%u)", (unsigned)e->values[0], (unsigned)e->values[1],
            (unsigned)e->values[2], (unsigned)e->values[3]);
  fprintf(stderr, "\n");
  return 1;
}

static int usage(void) {
  fprintf(stderr, "usage: fuse VIS.pgm TIR.pgm OUT.pgm adf|tsifsd|ifevip|adaptive [flight|classic] [strips]\n");
  return 2;
}

int main(int argc, char **argv) {
  if (argc < 5 || argc > 7) return usage();
  FusionConfig cfg = fusion_config_default();
  const char *methods[] = {"adf", "tsifsd", "ifevip", "adaptive"};
  const uint32_t method_values[] = {FUSION_METHOD_ADF, FUSION_METHOD_TSIFSD, FUSION_METHOD_IFEVIP,
                                    FUSION_METHOD_ADAPTIVE};
  int known = 0;
  for (int i = 0; i < 4; i++)
    if (strcmp(argv[4], methods[i]) == 0) cfg.method = method_values[i], known = 1;
  if (!known) return usage();
  int strips = 0;
  for (int i = 5; i < argc; i++) {
    if (strcmp(argv[i], "flight") == 0) cfg.variant = FUSION_VARIANT_FLIGHT;
    else if (strcmp(argv[i], "classic") == 0) cfg.variant = FUSION_VARIANT_CLASSIC;
    else if (strcmp(argv[i], "strips") == 0) strips = 1;
    else return usage();
  }

  size_t vw, vh, tw, th, w, h, bytes;
  unsigned char *vis_px = read_pgm(argv[1], &vw, &vh);
  if (!vis_px) return 1;
  unsigned char *tir_px = read_pgm(argv[2], &tw, &th);
  if (!tir_px) return 1;

  FusionError err;
  if (fusion_output_size(&cfg, vw, vh, tw, th, &w, &h, &err) != FUSION_STATUS_OK) return fail("sizes", &err);
  if (strips) {
    bytes = FUSION_STRIP_SCRATCH_BYTES;
  } else if (fusion_scratch_bytes(&cfg, vw, vh, tw, th, &bytes, &err) != FUSION_STATUS_OK) {
    return fail("scratch size", &err);
  }
  unsigned char *out_px = malloc(w * h);
  void *scratch = malloc(bytes); /* malloc's alignment is at least 8 */
  if (!out_px || !scratch) {
    fprintf(stderr, "fuse: out of memory (%u bytes of scratch)\n", (unsigned)bytes);
    return 1;
  }

  FusionImage vis = {vis_px, vw, vh, vw};
  FusionImage tir = {tir_px, tw, th, tw};
  FusionImageMut out = {out_px, w, h, w};
  FusionReport report;
  FusionStatus status = strips ? fusion_fuse_strips(&cfg, &vis, &tir, &out, scratch, bytes, SIZE_MAX, &report, &err)
                               : fusion_fuse(&cfg, &vis, &tir, &out, scratch, bytes, &report, &err);
  if (status != FUSION_STATUS_OK) return fail("fusion", &err);
  if (write_pgm(argv[3], out_px, w, h) != 0) return 1;
  printf("fused %ux%u (%s), guards 0x%x%s\n", (unsigned)w, (unsigned)h, report.rescaled ? "TIR rescaled" : "same grid",
         (unsigned)report.guards, strips ? ", strips" : "");
  free(scratch);
  free(out_px);
  free(tir_px);
  free(vis_px);
  return 0;
}
