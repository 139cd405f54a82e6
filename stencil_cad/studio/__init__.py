"""The studio: a local web page where the maker sees the sprayed result change as they choose, then makes the job.

:mod:`.app` holds the routes, :mod:`.jobs` the worker that makes a job, :mod:`.workspace` the one folder
the studio writes in, :mod:`.settings` the page's settings as a job config and :mod:`.server` the
uvicorn server (``stencil-cad studio``). The page (``static/``) is plain HTML, CSS and JavaScript.
"""

from .app import create_app
from .server import serve
from .workspace import Workspace, default_workspace

__all__ = ["Workspace", "create_app", "default_workspace", "serve"]
