/* The native splitter of the bytes-level data path (issue #20), CPython C API.
 *
 * split(buf, pos, max_xml) -> [(start, end), ...]: the XML spans of the complete plain Message
 * frames of `buf` from `pos` on, exactly as pure.split_plain returns them: tag "Message\0"
 * (OA-FRAME-1), L <= max_xml (OA-LIM-1), the whole frame present, and no "binarysizes" in the
 * XML in any case (such a frame may carry chunks, OA-FRAME-4: the reader decides). It stops at
 * the first frame that is not plain or not complete. No state, no allocation but the result.
 *
 * find_marker(buf, start, end) -> bool: the same search for "binarysizes", for FrameReader.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <string.h>

static const char TAG[8] = {'M', 'e', 's', 's', 'a', 'g', 'e', '\0'};
static const char MARKER[] = "binarysizes";
#define MARKER_LEN 11

static int lower(unsigned char c) { return (c >= 'A' && c <= 'Z') ? c + 32 : c; }

/* Whether "binarysizes" occurs in [p, p+n) ignoring ASCII case. Linear: the next 'b' and the
 * next 'B' are each searched for again only once the scan has passed them (searching for both
 * after every candidate was quadratic on a text of "bx" repeated). */
static int has_marker(const unsigned char *p, Py_ssize_t n) {
    const unsigned char *end = p + n, *cur = p, *next_b = NULL, *next_B = NULL;
    while (end - cur >= MARKER_LEN) {
        if (next_b == NULL || next_b < cur) {
            next_b = memchr(cur, 'b', (size_t)(end - cur));
            if (next_b == NULL) next_b = end;
        }
        if (next_B == NULL || next_B < cur) {
            next_B = memchr(cur, 'B', (size_t)(end - cur));
            if (next_B == NULL) next_B = end;
        }
        const unsigned char *c = next_b < next_B ? next_b : next_B;
        if (end - c < MARKER_LEN) return 0;
        Py_ssize_t k = 1;
        while (k < MARKER_LEN && lower(c[k]) == MARKER[k]) k++;
        if (k == MARKER_LEN) return 1;
        cur = c + 1;
    }
    return 0;
}

/* find_marker(buf, start, end) -> bool: whether "binarysizes" occurs in buf[start:end] in any
 * case (FrameReader's search for the marker, OA-FRAME-4), clipped to the buffer. */
static PyObject *find_marker(PyObject *self, PyObject *args) {
    Py_buffer view;
    Py_ssize_t start, end;
    if (!PyArg_ParseTuple(args, "y*nn", &view, &start, &end)) return NULL;
    if (start < 0) start = 0;
    if (end > view.len) end = view.len;
    int found = end > start && has_marker((const unsigned char *)view.buf + start, end - start);
    PyBuffer_Release(&view);
    return PyBool_FromLong(found);
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
    {"find_marker", find_marker, METH_VARARGS, "Whether buf[start:end] holds binarysizes."},
    {NULL, NULL, 0, NULL},
};

static struct PyModuleDef module = {
    PyModuleDef_HEAD_INIT, "_native", "The data path's native frame splitter (issue #20).", -1,
    methods,
};

PyMODINIT_FUNC PyInit__native(void) { return PyModule_Create(&module); }
