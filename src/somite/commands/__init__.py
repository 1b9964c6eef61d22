"""Sub-commands of the ``somite`` CLI; each module has HELP, add_arguments(parser), run(args)."""
