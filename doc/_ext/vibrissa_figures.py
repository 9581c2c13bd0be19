"""
Sphinx extension: figures drawn by the project's own commands while the site is built.

A ``vibrissa-figure`` directive holds one ``vibrissa scan ... --plot NAME.png`` command. The
page shows the command as the reader would type it; the build runs it (``vibrissa_ros.cli``, in
a temporary folder where ``config/`` is the package's), writes the PNG into the build folder and
shows it. A command that fails is an error of the build, so every figure command in the
documentation is executed and works. The optional argument is the caption::

    ```{vibrissa-figure} The catenary, back and forth.
    vibrissa scan --profile catenary --param p0=0.5 --param c=0.6 --from 1.5 --to -1.5 \
        --step 0.005 --back --csv catenary.csv --plot catenary.png --small-png
    ```
"""

import contextlib
import hashlib
import io
import os
import shlex
import tempfile
from pathlib import Path

from docutils import nodes
from docutils.parsers.rst import directives
from sphinx.util.docutils import SphinxDirective


def package_root(config_root):
    """Return the folder holding ``config/``: the source checkout or the installed share folder."""
    candidates = [config_root] if config_root else []
    import vibrissa_ros

    candidates.append(str(Path(vibrissa_ros.__file__).resolve().parents[1]))
    try:
        from ament_index_python.packages import get_package_share_directory

        candidates.append(get_package_share_directory("vibrissa_ros"))
    except Exception:  # noqa: BLE001 (no ament index: a pip install or a source checkout)
        pass
    for candidate in candidates:
        if candidate and (Path(candidate) / "config").is_dir():
            return Path(candidate)
    raise RuntimeError("vibrissa_figures: no config/ folder found beside vibrissa_ros")


def run_command(command, workdir):
    """Run one ``vibrissa ...`` command line in ``workdir``; return (status, its output)."""
    from vibrissa_ros.cli import main

    argv = shlex.split(command)
    if argv[0] != "vibrissa":
        raise ValueError(f"not a vibrissa command: {command!r}")
    out = io.StringIO()
    cwd = os.getcwd()
    os.chdir(workdir)
    try:
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(out):
            try:
                status = main(argv[1:])
            except SystemExit as exc:
                status = exc.code
    finally:
        os.chdir(cwd)
    return status or 0, out.getvalue()


class VibrissaFigure(SphinxDirective):
    """Show a ``vibrissa`` command that draws a figure, run it, and show the figure."""

    has_content = True
    optional_arguments = 1
    final_argument_whitespace = True
    option_spec = {"alt": directives.unchanged, "width": directives.unchanged}

    def run(self):
        """Return the command's literal block and the figure it drew."""
        command = " ".join(line.rstrip("\\").strip() for line in self.content if line.strip())
        argv = shlex.split(command)
        if "--plot" not in argv:
            raise self.error(f"vibrissa-figure: the command has no --plot: {command}")
        shown = nodes.literal_block("\n".join(self.content), "\n".join(self.content))
        shown["language"] = "bash"

        build = Path(self.env.app.doctreedir).parent / "vibrissa_figures"
        build.mkdir(parents=True, exist_ok=True)
        digest = hashlib.sha1(command.encode()).hexdigest()[:12]
        target = build / f"{Path(argv[argv.index('--plot') + 1]).stem}-{digest}.png"
        argv[argv.index("--plot") + 1] = str(target)
        root = package_root(self.config.vibrissa_root)
        with tempfile.TemporaryDirectory() as tmp:
            os.symlink(root / "config", Path(tmp) / "config")
            status, output = run_command(shlex.join(argv), tmp)
        if status != 0 or not target.is_file():
            raise self.error(f"vibrissa-figure: {command} exited with {status}:\n{output}")

        docdir = Path(self.env.doc2path(self.env.docname)).parent
        image = nodes.image(uri=os.path.relpath(target, docdir),
                            alt=self.options.get("alt", self.arguments[0] if self.arguments
                                                 else command))
        if "width" in self.options:
            image["width"] = self.options["width"]
        if not self.arguments:
            return [shown, image]
        figure = nodes.figure("", image)
        caption_nodes, _ = self.state.inline_text(self.arguments[0], self.lineno)
        figure += nodes.caption(self.arguments[0], "", *caption_nodes)
        return [shown, figure]


def setup(app):
    """Register the directive and the ``vibrissa_root`` setting."""
    app.add_config_value("vibrissa_root", "", "env")
    app.add_directive("vibrissa-figure", VibrissaFigure)
    return {"version": "1.0", "parallel_read_safe": True, "parallel_write_safe": True}
