/* The native splitter of the bytes-level data path (issue #20), CPython C API.
 *
 * split(buf, pos, max_xml) -> [(start, end), ...]: the XML spans of the complete plain Message
 * frames of `buf` from `pos` on, exactly as pure.split_plain returns them: tag "Message\0"
 * (OA-FRAME-1), L <= max_xml (OA-LIM-1), the whole frame present, and no "binarysizes" in the
 * XML in any case (such a frame may carry chunks, OA-FRAME-4: the reader decides). It stops at
 * the first frame that is not plain or not complete. No state, no allocation but the result.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <string.h>

static const char TAG[8] = {'M', 'e', 's', 's', 'a', 'g', 'e', '\0'};
static const char MARKER[] = "binarysizes";
#define MARKER_LEN 11

static int lower(unsigned char c) { return (c >= 'A' && c <= 'Z') ? c + 32 : c; }

/* Whether "binarysizes" occurs in [p, p+n) ignoring ASCII case. */
static int has_marker(const unsigned char *p, Py_ssize_t n) {
    for (Py_ssize_t i = 0; i + MARKER_LEN <= n; i++) {
        int c = lower(p[i]);
        if (c != 'b') {
            /* skip quickly to the next 'b' or 'B' */
            const unsigned char *b1 = memchr(p + i + 1, 'b', (size_t)(n - i - 1));
            const unsigned char *b2 = memchr(p + i + 1, 'B', (size_t)(n - i - 1));
            const unsigned char *next = b1 == NULL ? b2 : (b2 == NULL || b1 < b2 ? b1 : b2);
            if (next == NULL) return 0;
            i = (next - p) - 1;
            continue;
        }
        Py_ssize_t k = 1;
        while (k < MARKER_LEN && lower(p[i + k]) == MARKER[k]) k++;
        if (k == MARKER_LEN) return 1;
    }
    return 0;
}

static PyObject *split(PyObject *self, PyObject *args) {
    Py_buffer view;
    Py_ssize_t pos, max_xml;
    if (!PyArg_ParseTuple(args, "y*nn", &view, &pos, &max_xml)) return NULL;
    PyObject *spans = PyList_New(0);
    if (spans == NULL) goto done;
    const unsigned char *buf = view.buf;
    Py_ssize_t n = view.len;
    if (pos < 0) pos = 0;
    while (n - pos >= 12 && memcmp(buf + pos, TAG, 8) == 0) {
        const unsigned char *h = buf + pos + 8;
        Py_ssize_t length = (Py_ssize_t)((uint32_t)h[0] | (uint32_t)h[1] << 8 |
                                         (uint32_t)h[2] << 16 | (uint32_t)h[3] << 24);
        Py_ssize_t start = pos + 12, end = start + length;
        if (length > max_xml || end > n || has_marker(buf + start, length)) break;
        PyObject *span = Py_BuildValue("(nn)", start, end);
        if (span == NULL || PyList_Append(spans, span) < 0) {
            Py_XDECREF(span);
            Py_CLEAR(spans);
            goto done;
        }
        Py_DECREF(span);
        pos = end;
    }
done:
    PyBuffer_Release(&view);
    return spans;
}

static PyMethodDef methods[] = {
    {"split", split, METH_VARARGS, "Return the XML spans of the complete plain Message frames."},
    {NULL, NULL, 0, NULL},
};

static struct PyModuleDef module = {
    PyModuleDef_HEAD_INIT, "_native", "The data path's native frame splitter (issue #20).", -1,
    methods,
};

PyMODINIT_FUNC PyInit__native(void) { return PyModule_Create(&module); }
