"""The top camera's model and the depth crops the tangle CNN sees."""
