"""The comparison report: report.json, PNG images and the speed-against-accuracy charts, drawn without matplotlib
(pure).
"""
