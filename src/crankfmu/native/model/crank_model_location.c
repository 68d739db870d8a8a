/* A native FMU's model file found where the host says its resources are (fmi2's
 * fmuResourceLocation, a file: URI; fmi3's resourcePath, a path) and read whole, for md_parse
 * (crank_model_file.c) to check and read: crank_variables.h's md_load. A missing or unreadable file
 * and a location that is not a file are refused with the path. */
#include "crank_variables.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int hex_digit(int c) { return c >= '0' && c <= '9' ? c - '0' : c >= 'a' && c <= 'f' ? c - 'a' + 10 : c >= 'A' && c <= 'F' ? c - 'A' + 10 : -1; }

/* a file: URI (file:///C:/x, file:/x, file://localhost/x, percent-escapes) to a path; 0 if it is not one */
static int uri_path(const char* uri, char* out, size_t size)
{
    if (strncmp(uri, "file:", 5) != 0) return 0;
    const char* p = uri + 5;
    if (p[0] == '/' && p[1] == '/') {                      /* an authority: empty or localhost */
        p += 2;
        if (strncmp(p, "localhost", 9) == 0) p += 9;
        if (*p != '/') return 0;
    }
    /* /C:/... is a Windows drive */
    if (p[0] == '/' && ((p[1] >= 'A' && p[1] <= 'Z') || (p[1] >= 'a' && p[1] <= 'z')) && (p[2] == ':' || p[2] == '|'))
        p++;
    size_t n = 0;
    for (; *p; p++) {
        int c = (unsigned char)*p;
        if (c == '%' && hex_digit(p[1]) >= 0 && hex_digit(p[2]) >= 0) {
            c = hex_digit(p[1]) * 16 + hex_digit(p[2]);
            p += 2;
        }
        if (n + 1 >= size) return 0;
        out[n++] = (char)c;
    }
    out[n] = 0;
    return 1;
}

ModelData* md_load(const char* resources, int is_uri, char* why, size_t why_size)
{
    char folder[4096], path[4200];
    if (!resources || !*resources) {
        snprintf(why, why_size, "no resource location was given: this FMU reads its model from resources/%s",
                 CM_MODEL_FILE);
        return NULL;
    }
    if (is_uri) {
        if (!uri_path(resources, folder, sizeof folder)) {
            snprintf(why, why_size, "the resource location %s is not a file: URI: this FMU reads its model from "
                     "resources/%s", resources, CM_MODEL_FILE);
            return NULL;
        }
    } else {
        snprintf(folder, sizeof folder, "%s", resources);
    }
    size_t n = strlen(folder);
    int separated = n > 0 && (folder[n - 1] == '/' || folder[n - 1] == '\\');
    snprintf(path, sizeof path, "%s%s%s", folder, separated ? "" : "/", CM_MODEL_FILE);
    FILE* f = fopen(path, "rb");
    if (!f) {
        snprintf(why, why_size, "the model file %s is missing (or cannot be opened): this FMU's binary runs the model it "
                 "reads there", path);
        return NULL;
    }
    unsigned char* bytes = NULL;
    size_t size = 0, capacity = 0;
    for (;;) {
        if (size == capacity) {
            capacity = capacity ? 2 * capacity : 65536;
            unsigned char* grown = capacity <= ((size_t)1 << 30) ? (unsigned char*)realloc(bytes, capacity) : NULL;
            if (!grown) {
                free(bytes);
                fclose(f);
                snprintf(why, why_size, "the model file %s could not be read: too large, or out of memory", path);
                return NULL;
            }
            bytes = grown;
        }
        size_t got = fread(bytes + size, 1, capacity - size, f);
        size += got;
        if (got == 0) break;
    }
    int failed = ferror(f);
    fclose(f);
    ModelData* d = NULL;
    if (failed) snprintf(why, why_size, "the model file %s could not be read", path);
    else d = md_parse(bytes, size, path, why, why_size);
    free(bytes);
    return d;
}
