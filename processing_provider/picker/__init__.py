"""The fotogeo GCP picker (issue 14): a dock to pick GCPs on an image and on QGIS's map, with the model live.

Modules: :mod:`.gcp_layer` (the GCP point layer and its fields), :mod:`.commands` (undo/redo),
:mod:`.fit` (the worker session's ``fit_gcps`` and the prediction grids), :mod:`.image_source`
(the image in pixel units), :mod:`.canvas_items` (markers, residual arrows, predictions),
:mod:`.map_tools` (click / drag / delete, snapping), :mod:`.controller` (the state that ties them;
the refit in a thread),
:mod:`.table` (residual table, sortable), :mod:`.files` (.points and ODM gcp_list.txt), :mod:`.tasks`
(worker tools in a QgsTask), :mod:`.preview` (the live preview: the image warped onto the map in
a thread), :mod:`.dock` (the widget) and :mod:`.dock_actions` (its buttons). Nothing here imports fotogeo's numpy
code: fitting, proposals and file conversions run in fotogeo's worker (``processing_provider.runtime``).
"""
