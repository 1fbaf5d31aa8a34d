"""src/mdl/targets/python"""
