"""Presentation: figures (matplotlib, PNG), the HTML report and the demo.

Importing the package makes sure matplotlib has a writable folder for its settings and
font cache before any module here imports it (`_mpl_folder.prepare_matplotlib_folder`).
"""

from kinsync.report._mpl_folder import prepare_matplotlib_folder

prepare_matplotlib_folder()
