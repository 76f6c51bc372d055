/* Bands of a chain difference (step 4 of exporter/mesh/coverage.py): the module
 * exporter.mesh._band around bands.h, which holds the algorithm, its sources and the data form.
 * region_bands is the kernel; walk and band_width expose its two steps on their own (tests compare
 * them with the former plain-Python walk and widths). In-plane metres.
 */
#include "bands.h"

#define KERNEL "band.region_bands"

/* region_bands(region, a, b, side, by_start (d,) int64, xy (d, 2) float64, good (r,) bool,
 * width (r,) float64, max_edges, half): in place on good and width. region sorted ascending within
 * [0, r), by_start the rows by (region, a, row). */
static PyObject *py_region_bands(PyObject *self, PyObject *args) {
    PyObject *objs[8], *result = NULL;
    PyArrayObject *arr[8] = {NULL};
    long long max_edges;
    double half;
    if (!PyArg_ParseTuple(args, "OOOOOOOOLd:region_bands", &objs[0], &objs[1], &objs[2],
                          &objs[3], &objs[4], &objs[5], &objs[6], &objs[7], &max_edges, &half))
        return NULL;
    static const char *names[5] = {"region", "a", "b", "side", "by_start"};
    for (int i = 0; i < 5; i++) arr[i] = k_array(objs[i], NPY_INT64, 1, 0, KERNEL, names[i]);
    arr[5] = k_array(objs[5], NPY_FLOAT64, 2, 0, KERNEL, "xy");
    arr[6] = k_array(objs[6], NPY_BOOL, 1, 1, KERNEL, "good");
    arr[7] = k_array(objs[7], NPY_FLOAT64, 1, 1, KERNEL, "width");
    if (PyErr_Occurred()) goto done;
    npy_intp d = PyArray_DIM(arr[0], 0), r = PyArray_DIM(arr[6], 0);
    for (int i = 1; i < 5; i++)
        if (k_dim(arr[i], 0, d, KERNEL, names[i])) goto done;
    if (k_dim(arr[5], 0, d, KERNEL, "xy") || k_dim(arr[5], 1, 2, KERNEL, "xy") ||
        k_dim(arr[7], 0, r, KERNEL, "width") || k_indices(arr[0], r, KERNEL, "region") ||
        k_indices(arr[4], d, KERNEL, "by_start"))
        goto done;
    const int64_t *region = K_I64(arr[0]), *by_start = K_I64(arr[4]);
    for (npy_intp t = 0; t < d; t++) {
        /* The walk stays within each region's rows. */
        if ((t && region[t] < region[t - 1]) || region[by_start[t]] != region[t]) {
            PyErr_SetString(PyExc_ValueError,
                            KERNEL ": region must be sorted and by_start keep each region's rows");
            goto done;
        }
    }
    int status;
    Py_BEGIN_ALLOW_THREADS
    status = region_bands(region, K_I64(arr[1]), K_I64(arr[2]), K_I64(arr[3]), by_start,
                          K_F64(arr[5]), d, K_BOOL(arr[6]), K_F64(arr[7]), max_edges, half);
    Py_END_ALLOW_THREADS
    if (status < 0) {
        PyErr_NoMemory();
        goto done;
    }
    result = Py_NewRef(Py_None);
done:
    for (int i = 0; i < 8; i++) Py_XDECREF(arr[i]);
    return result;
}

#undef KERNEL
#define KERNEL "band.walk"

/* walk(a, b, side, by_start, a_sorted (n,) int64, lo, hi, max_edges, cycle_of, order_in_cycle
 * (n,) int64 outputs): the cycles of rows lo..hi-1 (bands.h, band_walk); their count or -1. */
static PyObject *py_walk(PyObject *self, PyObject *args) {
    PyObject *objs[7], *result = NULL;
    PyArrayObject *arr[7] = {NULL};
    long long lo, hi, max_edges;
    npy_bool *used = NULL;
    int64_t *options = NULL;
    if (!PyArg_ParseTuple(args, "OOOOOLLLOO:walk", &objs[0], &objs[1], &objs[2], &objs[3],
                          &objs[4], &lo, &hi, &max_edges, &objs[5], &objs[6]))
        return NULL;
    static const char *names[7] = {"a", "b", "side", "by_start", "a_sorted", "cycle_of",
                                   "order_in_cycle"};
    for (int i = 0; i < 7; i++) arr[i] = k_array(objs[i], NPY_INT64, 1, i >= 5, KERNEL, names[i]);
    if (PyErr_Occurred()) goto done;
    npy_intp n = PyArray_DIM(arr[0], 0);
    for (int i = 1; i < 7; i++)
        if (k_dim(arr[i], 0, n, KERNEL, names[i])) goto done;
    if (lo < 0 || hi < lo || hi > n) {
        PyErr_SetString(PyExc_ValueError, KERNEL ": lo, hi out of range");
        goto done;
    }
    const int64_t *by_start = K_I64(arr[3]);
    for (int64_t t = lo; t < hi; t++) {
        if (by_start[t] < lo || by_start[t] >= hi) {
            PyErr_SetString(PyExc_ValueError, KERNEL ": by_start leaves rows lo..hi-1");
            goto done;
        }
    }
    size_t size = hi > lo ? (size_t)(hi - lo) : 1;
    used = malloc(size * sizeof(npy_bool));
    options = malloc(size * sizeof(int64_t));
    if (!used || !options) {
        PyErr_NoMemory();
        goto done;
    }
    int64_t cycles;
    Py_BEGIN_ALLOW_THREADS
    cycles = band_walk(K_I64(arr[0]), K_I64(arr[1]), K_I64(arr[2]), by_start, K_I64(arr[4]), lo,
                       hi, max_edges, K_I64(arr[5]), K_I64(arr[6]), used, options);
    Py_END_ALLOW_THREADS
    result = PyLong_FromLongLong(cycles);
done:
    free(used);
    free(options);
    for (int i = 0; i < 7; i++) Py_XDECREF(arr[i]);
    return result;
}

#undef KERNEL
#define KERNEL "band.band_width"

/* band_width(x, y (n,) float64, side (n,) int64, half): the cycle's width (metres), NaN when it
 * is not a band (bands.h, band_width). */
static PyObject *py_band_width(PyObject *self, PyObject *args) {
    PyObject *x_obj, *y_obj, *side_obj, *result = NULL;
    double half;
    if (!PyArg_ParseTuple(args, "OOOd:band_width", &x_obj, &y_obj, &side_obj, &half)) return NULL;
    PyArrayObject *x = k_array(x_obj, NPY_FLOAT64, 1, 0, KERNEL, "x");
    PyArrayObject *y = k_array(y_obj, NPY_FLOAT64, 1, 0, KERNEL, "y");
    PyArrayObject *side = k_array(side_obj, NPY_INT64, 1, 0, KERNEL, "side");
    if (PyErr_Occurred()) goto done;
    npy_intp n = PyArray_DIM(x, 0);
    if (k_dim(y, 0, n, KERNEL, "y") || k_dim(side, 0, n, KERNEL, "side")) goto done;
    result = PyFloat_FromDouble(band_width(K_F64(x), K_F64(y), K_I64(side), n, half));
done:
    Py_XDECREF(x);
    Py_XDECREF(y);
    Py_XDECREF(side);
    return result;
}

static PyMethodDef methods[] = {
    {"region_bands", py_region_bands, METH_VARARGS,
     "region_bands(region, a, b, side, by_start, xy, good, width, max_edges, half): in place"},
    {"walk", py_walk, METH_VARARGS,
     "walk(a, b, side, by_start, a_sorted, lo, hi, max_edges, cycle_of, order_in_cycle): count"},
    {"band_width", py_band_width, METH_VARARGS,
     "band_width(x, y, side, half): a cycle's width across its chord (metres), NaN if no band"},
    {NULL, NULL, 0, NULL},
};

K_MODULE(band, "Bands of a chain difference: cycles and their widths (in-plane metres).", methods)
