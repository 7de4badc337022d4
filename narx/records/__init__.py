"""Input/output records and what is read from them before any model.

Typical use::

    from narx.records.csvdata import read_csv
    from narx.records.regressors import regressor_matrix

Modules: :mod:`~narx.records.data` (validated arrays and a per-record
column cache), :mod:`~narx.records.csvdata` (CSV files with one-line
errors), :mod:`~narx.records.regressors` and :mod:`~narx.records.colbuild`
(the regressor columns of terms on a record), :mod:`~narx.records.outliers`
(spikes found and repaired), :mod:`~narx.records.ranges` (signal ranges)
and :mod:`~narx.records.deadtime` (an input's dead time).
"""
